#!/usr/bin/env bash
# Writes every output a behaviour-preserving change must leave byte-identical, into OUT:
#
#   scripts/identity.sh OUT [S2G]
#
# then compare two builds' folders with `diff -r BEFORE AFTER`. Runs, each with its
# programs, JSON report, stderr's last line and exit status:
# - the bundled bunny with both policies at 256^3, per-setup and the 3+2 `ac` layout, the
#   `shop` preset and the grbl and Fanuc dialects (all `--reproducible`);
# - every STL of tests/data/meshes (the corpus, the stress parts and the edge cases) at
#   128^3 with the default policy, failures included;
# - every feature job of assets/jobs in every dialect, with `--json` and `--check 0.5`;
# - FDM reconstruction of every program of tests/data/fdm/gcode (STL, and STEP for one);
# - `s2g gcode stats` of every CNC program of tests/data/cnc/programs;
# - the field crate's five-axis cup program with a few Adam steps.
# S2G defaults to target/release/s2g. Takes about 3 minutes on two cores.
set -uo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

out=${1:?usage: scripts/identity.sh OUT [S2G]}
s2g=${2:-target/release/s2g}
mkdir -p "$out"
out=$(cd "$out" && pwd)

# run NAME ARGS...: runs s2g with ARGS, keeping stdout, stderr's last line and the status.
run() {
    local name=$1
    shift
    "$s2g" "$@" >"$out/$name.stdout" 2>"$out/$name.stderr.full"
    echo "$?" >"$out/$name.rc"
    tail -n 1 "$out/$name.stderr.full" >"$out/$name.stderr"
    rm -f "$out/$name.stderr.full"
}

bunny=assets/stanford_bunny.stl
for policy in learned heuristic; do
    run "bunny-$policy" mill "$bunny" --policy "$policy" --reproducible --json \
        -o "$out/bunny-$policy.ngc"
done
run bunny-ac mill "$bunny" --layout ac --reproducible --json -o "$out/bunny-ac.ngc"
run bunny-shop mill "$bunny" --preset shop --res 128 --reproducible --json \
    -o "$out/bunny-shop.ngc"
for dialect in grbl fanuc; do
    run "bunny-$dialect" mill "$bunny" --dialect "$dialect" --res 128 --reproducible --json \
        -o "$out/bunny-$dialect.ngc"
done

while IFS= read -r mesh; do
    name=mesh-$(basename "$(dirname "$mesh")")-$(basename "$mesh" .stl)
    run "$name" mill "$mesh" --res 128 --reproducible --json -o "$out/$name.ngc"
done < <(find tests/data/meshes -name '*.stl' | sort)

for job in assets/jobs/*.toml; do
    stem=$(basename "$job" .toml)
    for dialect in linuxcnc grbl fanuc; do
        run "job-$stem-$dialect" feature "$job" --dialect "$dialect" -o "$out/job-$stem-$dialect.ngc"
    done
    run "job-$stem-json" feature "$job" --json
    run "job-$stem-check" feature "$job" --check 0.5 -o "$out/job-$stem-check.ngc"
done

for program in tests/data/fdm/gcode/*.gcode; do
    stem=$(basename "$program" .gcode)
    run "fdm-$stem" reconstruct "$program" -o "$out/fdm-$stem.stl"
done
run fdm-step reconstruct tests/data/fdm/gcode/prusa_cube10_infill20_rectilinear.gcode \
    -o "$out/fdm-step.step"
run fdm-tubes reconstruct tests/data/fdm/gcode/slic3r_cube10_infill20_comments.gcode --tubes \
    -o "$out/fdm-tubes.stl"

for program in tests/data/cnc/programs/*; do
    run "gcode-$(basename "$program")" gcode stats "$program"
done

run field-cup field mill --cup --steps 20 --json -o "$out/field-cup.ngc"

# Reports name the programs they wrote: compare the names relative to OUT.
sed -i "s#$out/#OUT/#g" "$out"/*.stdout
# Wall-clock timings are the one thing allowed to differ.
sed -i -E 's/; [0-9.]+ s$/; T s/; s/"(seconds|total_seconds)": [0-9.e+-]+/"\1": T/' "$out"/*.stdout
