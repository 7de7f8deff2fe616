#!/usr/bin/env bash
# Camera/projector calibration views from the virtual probe, as the probe would deliver them:
# every capture of board_scene.json rendered over the whole sensor (9 laser columns over the
# board, LED edges 8 x 8 supersampled), the firmware's stripe centres beside each
# (`mlp-fw stripes`), and the views manifest OUT_DIR/views.json for `mlp calibrate`.
# usage: render_board_views.sh PROBE_FILE OUT_DIR [BIN_DIR]    (two renders at a time)
set -euo pipefail
probe=$(realpath "$1")
out=$2
bin=$(realpath "${3:-$(dirname "$0")/../../build/bin}")
scene=$(realpath "$(dirname "$0")/board_scene.json")
mkdir -p "$out"
cd "$out"
views=$(grep -o '"id": "view[0-9]*"' "$scene" | cut -d'"' -f4)
export probe scene bin
# shellcheck disable=SC2016  # expanded by the inner shell
echo "$views" | xargs -P 2 -I{} sh -c '"$bin/mlp-sim" render --probe "$probe" --scene "$scene" \
  --capture {} --aoi full --column-count 9 --led-supersampling 8 --seed "$(echo {} | tr -dc 0-9)" \
  --out {} >/dev/null && "$bin/mlp-fw" stripes --frames {} --out {}/stripes.json >/dev/null'
list=$(echo "$views" | sed 's/.*/"&"/' | paste -sd, -)
cat > views.json <<JSON
{"format": "mlprobe-board-views/1",
 "board": {"inner_cols": 9, "inner_rows": 6, "square_mm": 2.5},
 "views": [$list]}
JSON
