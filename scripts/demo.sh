#!/usr/bin/env bash
# The README's main job: install, build, and run `mlp demo` (the whole job on the virtual
# machine: mlp-hostd, a virtual probe, hand-eye calibration, alignment -> G54, the bore before
# its finishing pass -> the finishing tool's radius in the tool table); then the pieces one by
# one: fits on the sample clouds (ground truth in samples/clouds/README.md), the virtual probe
# through the firmware, camera/projector calibration, the hand-eye on real line-scanner data.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
mlp=build/bin/mlp
echo "== The whole job on the virtual machine"
echo "\$ mlp demo"
"$mlp" demo
echo
run() { echo; echo "\$ mlp fit $*"; "$mlp" fit --text "$@"; }
echo "== Reference ball (d 25.4 mm at 250, -120, -310) with 2 % specks: robust vs plain least squares"
run sphere --method robust samples/clouds/reference_ball_cap.xyz
run sphere samples/clouds/reference_ball_cap.xyz
echo
echo "== Bore to be finished to d 60 (actual d 59.94): least squares, inscribed (functional) size, roundness"
run cylinder samples/clouds/bore_before_finish.xyz
run circle --method mic samples/clouds/bore_before_finish.xyz
run circle --method minzone samples/clouds/bore_before_finish.xyz
echo
echo "== Machined face: flatness (minimum zone)"
run plane --method minzone samples/clouds/top_face.xyz
echo
echo "== Real sensor cloud (PCL test data, metres): robust plane"
run plane --method robust --units m samples/data/pcl/sac_plane_test.pcd
echo
echo "== Virtual probe -> firmware -> fit: the sample block's top face, 120 mm below the probe"
cap=$(mktemp -d)
build/bin/mlp-sim render --probe samples/probes/reference_probe.json \
  --scene samples/scenes/bore_block.json --capture top_face --aoi 824,568,400,400 --out "$cap"
build/bin/mlp-fw run --probe samples/probes/reference_probe.json --frames "$cap" --roi full \
  --out "$cap/cloud.ply"
run plane "$cap/cloud.ply"
rm -rf "$cap"
echo
echo "== Camera + projector calibration: 16 chessboard views from the virtual probe (~45 s)"
views=$(mktemp -d)
bash samples/calib/render_board_views.sh samples/probes/reference_probe.json "$views"
echo "\$ mlp calibrate projector --views views.json --design reference_probe.json --out calibrated.json"
"$mlp" calibrate projector --views "$views/views.json" --design samples/probes/reference_probe.json \
  --out "$views/calibrated.json"
rm -rf "$views"
echo
echo "== Sphere hand-eye on real data: ten line-scanner profiles of a 25.4 mm ball on a robot"
echo "\$ mlp calibrate hand-eye --dry-run --captures samples/calib/line_scanner_ball.json"
"$mlp" calibrate hand-eye --dry-run --captures samples/calib/line_scanner_ball.json \
  --store "$(mktemp -d)"
