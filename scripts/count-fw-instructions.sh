#!/usr/bin/env bash
# Instructions the firmware spends per laser frame, counted exactly on aarch64 (the board's ISA,
# under qemu-aarch64: one translation block per instruction, each execution logged and counted)
# and on x86-64 (valgrind's callgrind). The cost per frame is the difference between two
# captures of the same window with N1 and N2 laser frames, divided by N2 - N1: start-up, the
# probe model and the LED frame cancel. Frames are PGM (on the board they come from V4L2
# buffers, not files: PGM reading is a copy, PNG decoding would not be).
# There is no arm64 hardware here and Debian's qemu 7.2 has no TCG plugins or cycle model, so
# times on a Cortex-A53/A72 are estimates from these counts (docs/BENCHMARKS.md says how).
# Usage: bash scripts/count-fw-instructions.sh   (after scripts/build.sh and scripts/build-arm64.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
sysroot=${MLP_ARM64_SYSROOT:-/var/cache/mlprobe/arm64-sysroot}
x86=build/bin/mlp-fw
arm=build-arm64/bin/mlp-fw
for f in "$x86" "$arm" build/bin/mlp-sim; do
  [[ -x $f ]] || { echo "count-fw-instructions: $f missing (build it first)" >&2; exit 2; }
done
command -v valgrind >/dev/null || { echo "count-fw-instructions: needs valgrind" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
probe=samples/probes/reference_probe.json
aoi=${MLP_AOI:-924,668,200,200}
n1=10 n2=40
for n in $n1 $n2; do
  # Columns 480, 482, ...: the top face's stripe crosses the window on every row.
  build/bin/mlp-sim render --probe "$probe" --scene samples/scenes/bore_block.json \
    --capture top_face --aoi "$aoi" --columns "480:$((480 + 2 * (n - 1))):2" --format pgm \
    --seed 7 --out "$work/c$n" >/dev/null
done

arm_count() {  # instructions executed by mlp-fw run on capture $1 under qemu-aarch64
  mkfifo "$work/trace"
  wc -l <"$work/trace" >"$work/count" &
  qemu-aarch64 -L "$sysroot" -singlestep -d exec,nochain -D "$work/trace" \
    "$arm" run --probe "$probe" --frames "$1" --roi full --out "$work/arm.ply" >/dev/null
  wait
  rm "$work/trace"
  cat "$work/count"
}
x86_count() {  # the same on x86-64
  valgrind --tool=callgrind --callgrind-out-file="$work/cg.out" \
    "$x86" run --probe "$probe" --frames "$1" --roi full --out "$work/x86.ply" >/dev/null 2>&1
  awk '/^summary:/ {print $2}' "$work/cg.out"
}

x86_seconds() {  # the fastest of 7 runs on this machine, as mlp-fw measures itself
  for _ in 1 2 3 4 5 6 7; do
    "$x86" run --probe "$probe" --frames "$1" --roi full --out "$work/t.ply" --json |
      awk -F': ' '/"seconds"/ {print $2}'
  done | sort -g | head -1
}

echo "count-fw-instructions: AOI $aoi, captures of $n1 and $n2 laser frames"
t1=$(x86_seconds "$work/c$n1")
t2=$(x86_seconds "$work/c$n2")
a1=$(arm_count "$work/c$n1")
a2=$(arm_count "$work/c$n2")
x1=$(x86_count "$work/c$n1")
x2=$(x86_count "$work/c$n2")
points=$("$x86" run --probe "$probe" --frames "$work/c$n2" --roi full --out "$work/p.ply" --json |
  awk -F'[:,]' '/"points"/ {gsub(/ /, "", $2); print $2}')
pixels=$(echo "$aoi" | awk -F, '{print $3 * $4}')
awk -v a1="$a1" -v a2="$a2" -v x1="$x1" -v x2="$x2" -v n1="$n1" -v n2="$n2" \
  -v px="$pixels" -v pts="$points" -v t1="$t1" -v t2="$t2" 'BEGIN {
  af = (a2 - a1) / (n2 - n1); xf = (x2 - x1) / (n2 - n1)
  printf "  aarch64: %d and %d instructions in all; %.0f per laser frame, %.1f per pixel\n", a1, a2, af, af / px
  printf "  x86-64:  %d and %d instructions in all; %.0f per laser frame, %.1f per pixel\n", x1, x2, xf, xf / px
  printf "  aarch64 / x86-64 per frame: %.2f; %d points from %d frames (%.0f per frame)\n", af / xf, pts, n2, pts / n2
  printf "  start-up and the rest (aarch64): %.0f instructions\n", a1 - n1 * af
  tf = (t2 - t1) / (n2 - n1)
  printf "  x86-64 here: %.3f ms per laser frame (fastest of 7), %.2f instructions per ns\n", tf * 1e3, xf / (tf * 1e9)
}'
