#!/usr/bin/env bash
# Time and peak memory of `s2g mill` (issue 32): every closed mesh of tests/data (the
# corpus and the stress corpus) at 256^3 with the default policy, the smallest and largest
# actions on example002, and the bunny at 1024^3. One line per run:
#   part  action  res  seconds  peak_MiB  IoU  gouge_voxels  rapid_collisions  exit
# Runs the release binary (built first); programs go to a temporary folder.
#
#   scripts/memory_sweep.sh [--quick]      # --quick: the corpus only, no 1024^3 run
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p shape2gcode-cli
s2g=target/release/s2g
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
printf '%-28s %-32s %5s %8s %9s %7s %7s %7s %4s\n' part action res seconds peak_MiB IoU gouges rapids exit
run() { # run MESH RES POLICY
    local mesh=$1 res=$2 policy=$3 name
    name=$(basename "$mesh" .stl)
    local code=0
    /usr/bin/time -f '%e %M' -o "$out/time" "$s2g" mill "$mesh" --res "$res" --policy "$policy" \
        -o "$out/p.ngc" --report "$out/r.json" >/dev/null 2>"$out/err" || code=$?
    # /usr/bin/time writes "Command exited with non-zero status N" first on a failure.
    read -r secs kib < <(tail -n 1 "$out/time") || true
    local iou=- gouges=- rapids=-
    if [ -s "$out/r.json" ]; then
        read -r iou gouges rapids < <(python3 -c 'import json,sys; r=json.load(open(sys.argv[1])); print("%.4f" % r["iou"], r["gouge_voxels"], r["rapid_collisions"])' "$out/r.json")
    fi
    printf '%-28s %-32s %5s %8s %9s %7s %7s %7s %4s\n' "$name" "$policy" "$res" "$secs" "$(( ${kib:-0} / 1024 ))" "$iou" "$gouges" "$rapids" "$code"
    rm -f "$out"/r.json "$out"/*.ngc
}
meshes=(tests/data/meshes/classic/stanford_bunny.stl tests/data/meshes/classic/gearwheel_40t.bin.stl
    tests/data/meshes/openscad/*.stl tests/data/meshes/stress/*.stl)
for m in "${meshes[@]}"; do
    run "$m" 256 learned
done
[ "${1:-}" = --quick ] && exit 0
e2=tests/data/meshes/openscad/openscad_Old_example002.stl
# The action space's extremes (paper preset: radii 0.1-1 mm, layers 0.195-1.56 mm on the
# 100 mm part), and a 0.4 mm end mill on 0.78 mm layers with each strategy.
for p in fixed-fine fixed-coarse fixed:0.4,0.78125,zigzag fixed:0.4,0.78125,periphery fixed:0.4,0.78125,spiral; do
    run "$e2" 256 "$p"
done
run tests/data/meshes/classic/stanford_bunny.stl 1024 learned
