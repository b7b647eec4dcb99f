#!/usr/bin/env bash
# Drop-cutter and waterline against OpenCAMLib (PyPI `opencamlib`), one thread each, in one
# run: the bundled bunny scaled to 100 mm and the 40-tooth gear wheel scaled to 60 mm, ball
# and bull cutters; prints CL points per second, the ratio, the largest height difference,
# and waterline loop counts, positions and times. Needs network access the first time
# (pip). Usage: scripts/bench_drop_cutter.sh [VENV_DIR]   (default target/ocl-venv)
set -euo pipefail
cd "$(dirname "$0")/.."
target="${CARGO_TARGET_DIR:-target}"
venv="${1:-$target/ocl-venv}"
if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
    "$venv/bin/pip" install --quiet opencamlib numpy
fi
cargo build --release -p s2g-geom --example drop_cutter
exe="$target/release/examples/drop_cutter"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$exe" prepare assets/stanford_bunny.stl "$tmp/bunny100.stl" 100
"$exe" prepare tests/data/meshes/classic/gearwheel_40t.bin.stl "$tmp/gear60.stl" 60
export OMP_NUM_THREADS=1 RAYON_NUM_THREADS=1
"$venv/bin/python" scripts/bench_drop_cutter.py "$exe" "$tmp"
