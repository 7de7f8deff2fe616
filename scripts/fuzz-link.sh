#!/usr/bin/env bash
# Builds the link's libFuzzer target, the job socket's request parser target and the image readers' target with clang (-fsanitize=fuzzer,address,undefined) and runs
# each for SECONDS (default 20: what CI runs; run them for hours by hand). The corpora are kept
# in build-fuzz/corpus and build-fuzz/corpus-requests between runs. Exit 0 only when no crash, leak or sanitizer report was found.
# Each source is compiled on its own through ccache (scripts/build-env.sh): a compile-and-link
# command is never cached, and three sanitized builds from scratch beside a loaded machine
# outlasted the test's guard once.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/build-env.sh
seconds=${1:-20}
out=build-fuzz
mkdir -p "$out/corpus" "$out/obj"
cc=(clang++)
if command -v ccache >/dev/null; then cc=(ccache clang++); fi
flags=(-std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all)

# fuzz_target NAME "INCLUDES" "LIBS" SOURCES...: the objects, then the fuzzer linked from them.
fuzz_target() {
  local name=$1 includes=$2 libs=$3
  shift 3
  local objects=()
  for source in "$@"; do
    local object="$out/obj/$name-${source//\//_}.o"
    # shellcheck disable=SC2086  # the include and library lists split into words on purpose
    "${cc[@]}" "${flags[@]}" $includes -c "$source" -o "$object"
    objects+=("$object")
  done
  # shellcheck disable=SC2086
  clang++ "${flags[@]}" "${objects[@]}" $libs -o "$out/$name"
}

fuzz_target link_frame_fuzz "-Iprobe_fw/link/include -Igeometry/base/include -I/usr/include/eigen3" \
  "-lcrypto -lzstd" probe_fw/link/src/{wire,auth,cloud_codec,messages}.cc \
  tests/fuzz/link_frame_fuzz.cc
"$out/link_frame_fuzz" -max_total_time="$seconds" -max_len=4096 -rss_limit_mb=1024 \
  -print_final_stats=1 "$out/corpus" 2>&1 | tail -n 12
mkdir -p "$out/corpus-requests"
fuzz_target job_request_fuzz "-Ihost/service/include -Igeometry/base/include" "" \
  host/service/src/request_json.cc tests/fuzz/job_request_fuzz.cc
"$out/job_request_fuzz" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=1024 \
  -print_final_stats=1 "$out/corpus-requests" 2>&1 | tail -n 12
mkdir -p "$out/corpus-images"
cp -n tests/fuzz/images/* "$out/corpus-images/"  # seeds: one valid file of each kind
fuzz_target image_fuzz \
  "-Iprobe_fw/format/include -Igeometry/include -Igeometry/base/include -I/usr/include/eigen3 -I/usr/include/opencv4" \
  "-lpng -lopencv_imgproc -lopencv_core" probe_fw/format/src/{frame_io,png_io,bmp_io}.cc \
  geometry/base/src/files.cc tests/fuzz/image_fuzz.cc
"$out/image_fuzz" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 \
  -print_final_stats=1 "$out/corpus-images" 2>&1 | tail -n 12
