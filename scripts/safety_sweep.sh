#!/usr/bin/env bash
# Safety sweep of `s2g mill`: every closed mesh of the corpus (and, where ../shared is
# checked out beside the repository, seven PrusaSlicer test and gallery shapes, AGPL, read
# in place and never copied) milled with fixed actions; prints one line per run and exits
# non-zero if any run gouges the part, rapids through material or fails.
#
#   scripts/safety_sweep.sh [S2G] [RES]
#   ACTIONS="fixed:0.75,0.3,zigzag fixed:2,0.78125,spiral" EXTRA="--roughing-depth 0" scripts/safety_sweep.sh
#
# S2G defaults to target/release/s2g (build it with `cargo build --release -p shape2gcode-cli`),
# RES to 128.
set -uo pipefail
cd "$(dirname "$0")/.."
s2g=${1:-target/release/s2g}
res=${2:-128}
actions=${ACTIONS:-"fixed:0.5,0.1953125,periphery fixed:2,0.78125,spiral fixed:0.25,0.390625,zigzag fixed:0.75,0.3,zigzag"}
extra=${EXTRA:-}
meshes=(tests/data/meshes/openscad/*.stl tests/data/meshes/classic/stanford_bunny.stl
    tests/data/meshes/classic/gearwheel_40t.bin.stl)
shared=../shared/data/extra/meshes
if [ -d "$shared" ]; then
    meshes+=("$shared"/cad_parts/prusaslicer_shape_M3_hex_nut.stl)
    for m in extruder_idler overhang sloping_hole cube_with_concave_hole two_hollow_squares ipadstand; do
        meshes+=("$shared/slicer_tests/$m.stl")
    done
fi
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
bad=0
for a in $actions; do
    for m in "${meshes[@]}"; do
        # shellcheck disable=SC2086 # EXTRA holds several arguments.
        "$s2g" mill "$m" --policy "$a" --res "$res" $extra --json -o "$out/p.ngc" >"$out/r.json" 2>"$out/e.txt"
        rc=$?
        line=$(python3 - "$out/r.json" "$out/e.txt" <<'PY'
import json, sys
try:
    r = json.load(open(sys.argv[1]))
except ValueError:
    print("ERROR", open(sys.argv[2]).read().strip().splitlines()[-1:])
    sys.exit()
bad = [(i + 1, s["gouge_voxels"], s["rapid_collision_lines"][:5])
       for i, s in enumerate(r["setups"]) if s["gouge_voxels"] or s["rapid_collision_lines"]]
print(f"iou {r['iou']:.4f}", "UNSAFE" if bad else "ok", bad if bad else "")
PY
)
        echo "$a $(basename "$m" .stl) rc=$rc $line"
        case "$line" in ok* | iou*" ok"*) ;; *) bad=$((bad + 1)) ;; esac
    done
done
echo "unsafe or failed runs: $bad"
[ "$bad" -eq 0 ]
