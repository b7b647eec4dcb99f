#!/usr/bin/env bash
# Finishing against roughing alone (issue 36): every closed mesh of tests/data (the
# OpenSCAD parts, the bunny and the gear, sized to 100 mm) and the five shop parts (their
# own millimetres), milled in the shop preset with `--finish` and with `--no-finish`; the
# same policy chooses the same roughing tool either way (with finishing, the deepest
# layers). Prints a Markdown table: Chamfer x1000 and normal consistency of both runs,
# gouges, rapids through material and holder collisions of both, machining time.
#
# The Chamfer distance and NC are scored at SAMPLES surface samples a mesh (default
# 100,000; at s2g's default 8,000 they move by about 0.01 and 0.003 between seeds).
#
#   scripts/finish_table.sh [S2G] [RES] [OUT_DIR] [SAMPLES]   (default target/release/s2g, 128, /tmp/s2g_finish_table, 100000)
set -euo pipefail
S2G=${1:-target/release/s2g}
RES=${2:-128}
OUT=${3:-/tmp/s2g_finish_table}
SAMPLES=${4:-100000}
mkdir -p "$OUT"
echo "| part | roughing tool | CD x1000 rough | CD x1000 finished | NC rough | NC finished | gouges (voxels, finish) | rapids, holder rough / finished | time rough / finished (h) |"
echo "| --- | --- | ---: | ---: | ---: | ---: | --- | --- | --- |"
parts=(tests/data/meshes/openscad/*.stl tests/data/meshes/classic/stanford_bunny.stl
       tests/data/meshes/classic/gearwheel_40t.bin.stl tests/data/meshes/shop/*.stl)
# PARTS="a.stl b.stl" scripts/finish_table.sh ...: those meshes only (the slow 256^3 rows one by one).
if [ -n "${PARTS:-}" ]; then read -ra parts <<< "$PARTS"; fi
for mesh in "${parts[@]}"; do
  name=$(basename "$mesh" .stl)
  size=(--size 100)
  case "$mesh" in */shop/*) size=() ;; esac
  for mode in no-finish finish; do
    "$S2G" mill "$mesh" --preset shop "${size[@]}" --res "$RES" --"$mode" --surface-spacing 0.2 \
      --metric-samples "$SAMPLES" --reproducible -o "$OUT/$name.$mode/p.ngc" --report "$OUT/$name.$mode.json" > "$OUT/$name.$mode.log" 2>&1 || true
  done
  python3 - "$OUT/$name.no-finish.json" "$OUT/$name.finish.json" "$name" <<'PY'
import json, sys
r, f = (json.load(open(p)) for p in sys.argv[1:3])
tools = ",".join(sorted({str(2 * s["tool_radius"]) for s in r["setups"]}))
gouged = sum(1 for s in f["setups"] if s.get("surface_deviation", {}).get("gouged"))
print(f"| {sys.argv[3]} | {tools} mm | {r['chamfer_x1000']:.4f} | {f['chamfer_x1000']:.4f} | "
      f"{r['normal_consistency']:.4f} | {f['normal_consistency']:.4f} | {f['gouge_voxels']}, {gouged} | "
      f"{r['rapid_collisions']}, {r['holder_collisions']} / {f['rapid_collisions']}, {f['holder_collisions']} | "
      f"{r['machining_time_s'] / 3600:.2f} / {f['machining_time_s'] / 3600:.2f} |")
PY
done
