#!/usr/bin/env bash
# Sets up and runs the demo: builds ridgeline (release) and synthesises a terrain from
# a sketch and real DEMs with in-process workers, writing out/demo/terrain.tif, a
# hillshade preview out/demo/preview.png and a report out/demo/report.json.
# DEMs: ../shared/data/dems when present (or $RIDGELINE_SHARED_DATA/dems); otherwise
# `ridgeline fetch-dem` downloads public elevation tiles for three areas first.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo not found; install the Rust toolchain (https://rustup.rs) and run again" >&2
  exit 1
fi
cargo build --release -p ridgeline
mkdir -p out/demo
DATA="${RIDGELINE_SHARED_DATA:-../shared/data}"
if [ -d "$DATA/dems" ]; then
  EXEMPLARS="$DATA/dems"
else
  echo "$DATA/dems not found: fetching public elevation tiles instead" >&2
  for area in alps rockies appalachians; do
    ./target/release/ridgeline fetch-dem --area "$area" --zoom 11 --out out/demo/exemplars
  done
  EXEMPLARS=out/demo/exemplars/manifest.toml
fi
SKETCH="${1:-$DATA/sketches/small-range-512.png}"
if [ ! -f "$SKETCH" ]; then
  # no shared sketch either: draw one (a ridge above a valley) with the binary's own tools
  SKETCH=out/demo/sketch.png
  python3 - "$SKETCH" <<'PY'
import struct, sys, zlib
w, h = 512, 512
rows = []
for y in range(h):
    row = bytearray([0])
    for x in range(w):
        v = 128
        if 40 < x < 470 and abs(y - (200 - (x - 256) * 0.3)) < 3: v = 255
        if 40 < x < 470 and abs(y - (380 + (x - 256) * 0.2)) < 3: v = 0
        row.append(v)
    rows.append(bytes(row))
def chunk(t, d): return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)) + chunk(b"IDAT", zlib.compress(b"".join(rows))) + chunk(b"IEND", b"")
open(sys.argv[1], "wb").write(png)
PY
fi
./target/release/ridgeline synth \
  --sketch "$SKETCH" \
  --exemplars "$EXEMPLARS" \
  --out out/demo/terrain.tif \
  --preview out/demo/preview.png \
  --debug-dir out/demo/debug \
  --report out/demo/report.json
echo "terrain: out/demo/terrain.tif   preview: out/demo/preview.png   report: out/demo/report.json   debug: out/demo/debug/"
echo "to sketch in the browser: ./target/release/ridgeline serve --exemplars $EXEMPLARS   (then open the address it prints)"
