#!/usr/bin/env bash
# Sets up and runs the demo: builds ridgeline (release) and synthesises a terrain from
# ../shared/data/sketches/small-range-512.png and the 16 real DEMs in
# ../shared/data/dems with in-process workers, writing out/demo/terrain.tif, a
# hillshade preview out/demo/preview.png and a report out/demo/report.json.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo not found; install the Rust toolchain (https://rustup.rs) and run again" >&2
  exit 1
fi
DATA="${RIDGELINE_SHARED_DATA:-../shared/data}"
SKETCH="${1:-$DATA/sketches/small-range-512.png}"
if [ ! -d "$DATA/dems" ]; then
  echo "error: $DATA/dems not found: the demo needs the shared DEMs beside the repository (or set RIDGELINE_SHARED_DATA)" >&2
  exit 1
fi
cargo build --release -p ridgeline
mkdir -p out/demo
./target/release/ridgeline synth \
  --sketch "$SKETCH" \
  --exemplars "$DATA/dems" \
  --out out/demo/terrain.tif \
  --preview out/demo/preview.png \
  --report out/demo/report.json
echo "terrain: out/demo/terrain.tif   preview: out/demo/preview.png   report: out/demo/report.json"
