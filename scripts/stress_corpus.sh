#!/usr/bin/env bash
# Remake the stress corpus of issue 32 (turned parts with 32-256 facets per circle, thin
# walls, holes of 1-2 voxels, nearly coplanar faces, parts 100x longer than thick):
# renders every tests/data/meshes/stress/src/*.scad to tests/data/meshes/stress/NAME.stl
# (binary STL), prints one line per part, then checks that every STL is closed with
# scripts/stl_check.py (where python3 is installed). Files whose first line starts with
# `// library` (e.g. bushing.scad) only define modules and are skipped.
#
#   scripts/stress_corpus.sh [NAME...]     # e.g. scripts/stress_corpus.sh bushing_256
#
# Needs openscad (2021.01 is known to work): apt-get install --no-install-recommends openscad
set -euo pipefail
cd "$(dirname "$0")/.."
dir=tests/data/meshes/stress
command -v openscad >/dev/null || { echo "openscad not found (apt-get install --no-install-recommends openscad)" >&2; exit 1; }
if [ $# -gt 0 ]; then
    srcs=()
    for n in "$@"; do srcs+=("$dir/src/${n%.scad}.scad"); done
else
    srcs=("$dir"/src/*.scad)
fi
log=$(mktemp)
trap 'rm -f "$log"' EXIT
outs=()
for src in "${srcs[@]}"; do
    if head -n 1 "$src" | grep -q '^// library'; then
        continue
    fi
    name=$(basename "$src" .scad)
    out=$dir/$name.stl
    start=$(date +%s.%N)
    if ! openscad --export-format binstl -o "$out" "$src" >"$log" 2>&1; then
        cat "$log" >&2
        echo "$name: openscad failed" >&2
        exit 1
    fi
    if grep -q -E '^(WARNING|ERROR)' "$log"; then
        grep -E '^(WARNING|ERROR)' "$log" >&2
    fi
    secs=$(echo "$(date +%s.%N) - $start" | bc)
    bytes=$(stat -c %s "$out")
    printf '%-16s %7d facets %9d bytes %6.1f s\n' "$name" $(((bytes - 84) / 50)) "$bytes" "$secs"
    outs+=("$out")
done
if [ ${#outs[@]} -gt 0 ] && command -v python3 >/dev/null; then
    python3 scripts/stl_check.py "${outs[@]}"
fi
