#!/usr/bin/env bash
# The shop acceptance sweep of issue 35: every closed mesh of tests/data (the OpenSCAD
# parts, the gear, the stress corpus, the bunny scaled to 100 mm) and the five shop parts
# (tests/data/meshes/shop) milled in the shop preset from a box stock with margin (the
# preset's default), with the default tool library and aluminium 6061; the tool table is
# written and every program runs through LinuxCNC's `rs274` with it. Prints one row per
# part: the report's IoU, an independent IoU (scripts/iou_check.py: column-parity voxels
# of the part and of the residual stock, pure Python), gouged voxels, rapids through
# material, holder collisions, whether `rs274` ran every program clean, and the machine's
# time. Exits non-zero if any run fails, is unsafe or any program fails in `rs274`.
#
#   scripts/shop_acceptance.sh [S2G] [RES] [CHECK_RES] [CHECK_RES2]
#
# S2G defaults to target/release/s2g (`cargo build --release -p shape2gcode-cli`), RES (the
# simulation's voxels along the stock's longest side) to 128, CHECK_RES (the independent
# scorer's) to 64; CHECK_RES2 (a second column, IoU** by the same scorer) to RES, so the
# score is also read at the simulation's own resolution (0 leaves it out). EXTRA adds arguments to every `s2g mill` (say EXTRA="--arc-tolerance 0"
# for straight programs; the preset fits arcs at 0.005 mm). ONLY="name name ..." runs those
# parts alone (file names without .stl).
#
# Parts a few millimetres thick are beyond RES voxels along their longest side (the long
# bar is 2 mm thick over 200 mm: 1.3 voxels at 128): the long bar, the long tube and the
# thin walls are simulated at 0.1 mm voxels (`--voxel 0.1`) and scored independently along
# exact columns of 0.05 mm cells (`iou_check.py --cell 0.05 --columns`), whatever RES and
# CHECK_RES say.
set -uo pipefail
cd "$(dirname "$0")/.."
s2g=${1:-target/release/s2g}
res=${2:-128}
check_res=${3:-64}
check_res2=${4:-$res}
extra=${EXTRA:-}
meshes=(tests/data/meshes/openscad/*.stl tests/data/meshes/classic/gearwheel_40t.bin.stl
    tests/data/meshes/classic/stanford_bunny.stl tests/data/meshes/stress/*.stl
    tests/data/meshes/shop/*.stl)
# KEEP=DIR keeps each part's programs, report and residual under DIR/NAME.
if [ -n "${KEEP:-}" ]; then
    out=$KEEP
    mkdir -p "$out"
else
    out=$(mktemp -d)
    trap 'rm -rf "$out"' EXIT
fi
bad=0
printf '| %-28s | %6s | %6s | %6s | %6s | %6s | %6s | %-7s | %9s |\n' part IoU "IoU*" "IoU**" gouges rapids holder rs274 "time (s)"
printf '| %-28s | %6s | %6s | %6s | %6s | %6s | %6s | %-7s | %9s |\n' --- ---: ---: ---: ---: ---: ---: --- ---:
for m in "${meshes[@]}"; do
    name=$(basename "$m" .stl)
    if [ -n "${ONLY:-}" ] && ! [[ " $ONLY " == *" $name "* ]]; then continue; fi
    grid=(--res "$res")
    check_args=("$check_res")
    check_args2=("$check_res2")
    case "$name" in long_bar | long_tube | thin_walls)
        grid=(--voxel 0.1)
        check_args=(--cell 0.05 --columns)
        check_args2=(0)
        ;;
    esac
    size=()
    # The bunny's file is in units of about a tenth of its size: mill it at 100 mm.
    case "$name" in stanford_bunny) size=(--size 100) ;; esac
    dir="$out/$name"
    mkdir -p "$dir"
    # shellcheck disable=SC2086 # EXTRA holds several arguments.
    nice "$s2g" mill "$m" --preset shop --material aluminium-6061 "${size[@]}" "${grid[@]}" \
        --tool-table "$dir/tool.tbl" --residual "$dir/residual.stl" --reproducible --json \
        $extra -o "$dir/p.ngc" >"$dir/r.json" 2>"$dir/e.txt"
    rc=$?
    clean=yes
    for p in "$dir"/p*.ngc; do
        [ -e "$p" ] || { clean=none; break; }
        if ! (cd "$dir" && HOME="$dir" rs274 -g -t "$dir/tool.tbl" "$p" </dev/null >/dev/null 2>"$dir/rs274.txt"); then
            clean=no
            echo "rs274 $name $(basename "$p"): $(grep -v '^executing' "$dir/rs274.txt" | head -2 | tr '\n' ' ')" >&2
        fi
    done
    # The residual is in the input mesh's units; scale the part as the run did.
    score() {
        python3 - "$m" "$dir" "$@" <<'PY'
import json, os, subprocess, sys
mesh, d, args = sys.argv[1], sys.argv[2], sys.argv[3:]
if args == ["0"] or not os.path.exists(os.path.join(d, "residual.stl")):
    print("-")
    sys.exit()
r = subprocess.run([sys.executable, "scripts/iou_check.py", mesh, os.path.join(d, "residual.stl"), *args],
                   capture_output=True, text=True)
print(r.stdout.split()[0] if r.returncode == 0 and r.stdout else "err")
PY
    }
    check=$(score "${check_args[@]}")
    check2=$(score "${check_args2[@]}")
    row=$(python3 - "$dir/r.json" "$dir/e.txt" "$name" "$rc" "$clean" "$check" "$check2" <<'PY'
import json, sys
path, err, name, rc, clean, check, check2 = sys.argv[1:]
try:
    r = json.load(open(path))
except ValueError:
    msg = (open(err).read().strip().splitlines() or ["no output"])[-1][:60]
    print(f"| {name:<28} | failed (status {rc}): {msg} |")
    sys.exit()
print(f"| {name:<28} | {r['iou']:6.4f} | {check:>6} | {check2:>6} | {r['gouge_voxels']:6d} | {r['rapid_collisions']:6d} "
      f"| {r['holder_collisions']:6d} | {clean:<7} | {r['machining_time_s']:9.0f} |")
PY
)
    echo "$row"
    case "$row" in *failed*) bad=$((bad + 1)) ;; esac
    [ "$rc" = 0 ] || bad=$((bad + 1))
    [ "$clean" = yes ] || bad=$((bad + 1))
done
echo "failed, unsafe or rs274-rejected: $bad"
echo "(IoU*: scripts/iou_check.py at $check_res^3, IoU** at $check_res2^3; simulation at $res^3; long_bar, long_tube, thin_walls: --voxel 0.1, IoU* at 0.05 mm columns)"
[ "$bad" -eq 0 ]
