#!/usr/bin/env bash
# Runs everything CI checks: formatting, clippy (warnings are errors) and the whole
# test suite in the release profile (one build profile for tests and demo).
# Tests that need ../shared/data skip with a message where it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
if ! command -v cargo >/dev/null 2>&1; then
  echo "error: cargo not found; install the Rust toolchain (https://rustup.rs) and run again" >&2
  exit 1
fi
rustup component add rustfmt clippy >/dev/null 2>&1 || true
# Mesa's software Vulkan driver (lavapipe), on which the GPU kernels' parity tests run
# where no GPU is present (they skip, saying so, only where no Vulkan adapter exists).
if ! ldconfig -p 2>/dev/null | grep -q libvulkan.so.1 || ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing mesa-vulkan-drivers and libvulkan1 (lavapipe) for the GPU parity tests" >&2
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null) ||
      echo "warning: could not install lavapipe; GPU parity tests will skip" >&2
  else
    echo "warning: no Vulkan driver and not root: GPU parity tests will skip (apt-get install mesa-vulkan-drivers libvulkan1)" >&2
  fi
fi
# Debian's Chromium for the web page's end-to-end test (driven by playwright-core,
# which cannot download a browser of its own here)
if [ ! -x /usr/bin/chromium ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "installing chromium for the web page's end-to-end test" >&2
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) ||
      echo "warning: could not install chromium" >&2
  fi
fi
# lavapipe warns at every start without a runtime dir
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
# deploy/ manifests against the Kubernetes and Compose schemas
bash scripts/check-deploy.sh
cargo fmt --all -- --check
# no import circles between the module files of any crate
python3 scripts/module-cycles.py terrain/src proto/src ops/src worker/src coordinator/src python/src
cargo clippy --workspace --all-targets --release -- -D warnings
cargo test --workspace --release
# the library without the command line's dependencies (what an embedding tool builds):
# the in-process CPU backend alone, none of the GPU's, the fleet's, the services' or the
# command line's crates; then each optional part on its own
cargo clippy -p ridgeline --release --no-default-features --lib --examples -- -D warnings
machinery=$(cargo tree -p ridgeline --no-default-features -e normal --prefix none | grep -E '^(wgpu|tonic|prost|tokio|axum|prometheus-client|clap|indicatif|ureq) ' | sort -u || true)
if [ -n "$machinery" ]; then
  echo "error: the library built without default features pulls in: $machinery" >&2
  exit 1
fi
for f in gpu fleet worker service; do
  cargo clippy -p ridgeline --release --no-default-features --features "$f" --lib -- -D warnings
done
# the web page end to end in headless Chromium (tests/web/e2e.mjs)
DATA="${RIDGELINE_SHARED_DATA:-../shared/data}"
if [ -d "$DATA/dems" ] && [ -x /usr/bin/chromium ] && command -v npm >/dev/null 2>&1; then
  npm ci --prefix tests/web --no-audit --no-fund --loglevel=error
  node tests/web/e2e.mjs target/release/ridgeline "$DATA" out/web/page.png
elif [ "${CI:-}" = true ]; then
  echo "error: the web end-to-end test needs $DATA/dems, /usr/bin/chromium and npm" >&2
  exit 1
else
  echo "SKIPPED: web end-to-end test (needs $DATA/dems, /usr/bin/chromium and npm)" >&2
fi
# the optional OpenTelemetry export (a cargo feature, off by default): lint and test it
cargo clippy -p ridgeline --release --features otlp --all-targets -- -D warnings
cargo test -p ridgeline --release --features otlp --test otlp
# what other tools read of the outputs, in a virtual environment of PyPI packages under
# target/: an OpenEXR terrain read back by the OpenEXR project's Python reader, bit for
# bit equal to the same job's float TIFF (tifffile); a georeferenced terrain and its
# tiles placed by rasterio (GDAL) where they lie
if ! python3 -c "import venv, ensurepip" >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null) ||
    echo "warning: could not install python3-venv" >&2
fi
PY=target/pyenv/bin/python
READERS="OpenEXR numpy tifffile rasterio"
if [ ! -x "$PY" ] || ! "$PY" -c "import OpenEXR, numpy, tifffile, rasterio" >/dev/null 2>&1; then
  python3 -m venv target/pyenv && "$PY" -m pip install -q --disable-pip-version-check $READERS ||
    { [ "${CI:-}" = true ] && { echo "error: the Python readers ($READERS from PyPI) could not be installed" >&2; exit 1; }; }
fi
if "$PY" -c "import OpenEXR, numpy, tifffile, rasterio" >/dev/null 2>&1 && [ -d "$DATA/sketches" ]; then
  out=target/readback && mkdir -p "$out"
  for ext in exr tif; do
    target/release/ridgeline synth --sketch "$DATA/sketches/small-range-512.png" --exemplars "$DATA/dems" \
      --out "$out/terrain.$ext" --no-cache --threads 2 --gpu off >/dev/null 2>&1
  done
  "$PY" tests/python/exr_readback.py "$out/terrain.exr" "$out/terrain.tif"
  target/release/ridgeline synth --sketch "$DATA/sketches/small-range-512.png" --exemplars "$DATA/dems" \
    --out "$out/geo.tif" --crs EPSG:32633 --origin 500000,4649776 --tiles 257 --no-cache --threads 2 --gpu off >/dev/null 2>&1
  "$PY" tests/python/geotiff_readback.py "$out/geo_tiles.json" 32633 500000 4649776
else
  echo "SKIPPED: the Python readback (needs $DATA and $READERS)" >&2
fi
# the Python package (python/, PyO3 through maturin): one abi3 wheel (CPython 3.9 and
# later) of the library without its default features, built from the repository in
# the shared target/ and release profile (dependencies whose features match the test
# build's are reused; the rest, the library among them, build once for the wheel's
# features and are then cached), installed into target/pyenv and tested with pytest
# (python/tests: the command line's terrain from an array, a PNG and strokes,
# determinism, progress, cancellation, Ctrl-C, bad inputs)
machinery=$(cargo tree -p ridgeline-python -e normal --prefix none | grep -E '^(wgpu|tonic|prost|tokio|axum|prometheus-client|clap|indicatif|ureq) ' | sort -u || true)
if [ -n "$machinery" ]; then
  echo "error: the Python package pulls in: $machinery" >&2
  exit 1
fi
PYPKG="maturin>=1.9.4,<2 pytest pillow"
if [ -x "$PY" ] && { [ ! -x target/pyenv/bin/maturin ] || ! "$PY" -c "import pytest, PIL" >/dev/null 2>&1; }; then
  "$PY" -m pip install -q --disable-pip-version-check $PYPKG ||
    { [ "${CI:-}" = true ] && { echo "error: the Python package's tools ($PYPKG from PyPI) could not be installed" >&2; exit 1; }; }
fi
if [ -x target/pyenv/bin/maturin ] && "$PY" -c "import numpy, tifffile, pytest, PIL" >/dev/null 2>&1; then
  rm -f target/wheels/ridgeline-*.whl
  target/pyenv/bin/maturin build --release -m python/Cargo.toml --out target/wheels --interpreter "$PY"
  "$PY" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps target/wheels/ridgeline-*.whl
  "$PY" -m pytest -q -p no:cacheprovider python/tests
elif [ "${CI:-}" = true ]; then
  echo "error: the Python package's test needs target/pyenv with maturin, pytest, pillow, numpy and tifffile" >&2
  exit 1
else
  echo "SKIPPED: the Python package (needs target/pyenv with $PYPKG numpy tifffile)" >&2
fi
