#!/usr/bin/env bash
# Remakes the five shop parts of issue 35 (flanged bushing, L-bracket, pocketed plate,
# stepped boss, T-slot block; mm, 60-100 mm) into tests/data/meshes/shop/ with their
# manifest.json, from `s2g gen --kind shop`:
#
#   scripts/make_shop_parts.sh [S2G]
#
# S2G defaults to the release binary, built first if it is missing. The output is
# deterministic: a second run leaves `git status` clean.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

target=${CARGO_TARGET_DIR:-target}
s2g=${1:-$target/release/s2g}
if [[ ! -x $s2g ]]; then
    cargo build --release -p shape2gcode-cli
fi
out=tests/data/meshes/shop
mkdir -p "$out"
"$s2g" gen --kind shop --out "$out"
