#!/usr/bin/env bash
# Checks the code that runs on the probe's ARM board (geometry + probe_fw) for ARMv8-A with
# Debian's cross compiler, warnings as errors: proof that the firmware carries no x86-only code.
# Compile only: the board's libraries (OpenCV) are not installed for arm64 here.
set -euo pipefail
cd "$(dirname "$0")/.."
cxx=aarch64-linux-gnu-g++
command -v "$cxx" >/dev/null || { echo "check-arm64: $cxx missing (scripts/install-deps.sh installs it)" >&2; exit 1; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
# -O0 code generation: an x86 target attribute passes -fsyntax-only and fails only here.
export cxx out
compile() {
  "$cxx" -std=c++20 -march=armv8-a -Wall -Wextra -Wpedantic -Werror -Wno-psabi \
    -fopenmp-simd -fno-math-errno -fno-trapping-math \
    -Igeometry/include -Iprobe_fw/include -Iprobe_fw/format/include -isystem /usr/include/eigen3 -isystem /usr/include/opencv4 \
    -O0 -c "$1" -o "$out/$(basename "$1").o"
}
export -f compile
ls geometry/src/*.cc probe_fw/format/src/*.cc probe_fw/src/*.cc | xargs -P "$(nproc)" -I{} bash -c 'compile {}'
echo "check-arm64: $(ls "$out" | wc -l) files compiled for armv8-a"
