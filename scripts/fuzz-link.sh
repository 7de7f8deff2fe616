#!/usr/bin/env bash
# Builds the link's libFuzzer target, the job socket's request parser target and the image readers' target with clang (-fsanitize=fuzzer,address,undefined) and runs
# each for SECONDS (default 20: what CI runs; run them for hours by hand). The corpora are kept
# in build-fuzz/corpus and build-fuzz/corpus-requests between runs. Exit 0 only when no crash, leak or sanitizer report was found.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-20}
out=build-fuzz
mkdir -p "$out/corpus"
clang++ -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
  -Iprobe_fw/link/include -Igeometry/base/include -I/usr/include/eigen3 \
  probe_fw/link/src/{wire,auth,cloud_codec,messages}.cc tests/fuzz/link_frame_fuzz.cc \
  -lcrypto -lzstd -o "$out/link_frame_fuzz"
"$out/link_frame_fuzz" -max_total_time="$seconds" -max_len=4096 -rss_limit_mb=1024 \
  -print_final_stats=1 "$out/corpus" 2>&1 | tail -n 12
mkdir -p "$out/corpus-requests"
clang++ -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
  -Ihost/service/include -Igeometry/base/include host/service/src/request_json.cc \
  tests/fuzz/job_request_fuzz.cc \
  -o "$out/job_request_fuzz"
"$out/job_request_fuzz" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=1024 \
  -print_final_stats=1 "$out/corpus-requests" 2>&1 | tail -n 12
mkdir -p "$out/corpus-images"
cp -n tests/fuzz/images/* "$out/corpus-images/"  # seeds: one valid file of each kind
clang++ -std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all \
  -Iprobe_fw/format/include -Igeometry/include -Igeometry/base/include -I/usr/include/eigen3 \
  -I/usr/include/opencv4 probe_fw/format/src/{frame_io,png_io,bmp_io}.cc \
  geometry/base/src/files.cc tests/fuzz/image_fuzz.cc \
  -lpng -lopencv_imgproc -lopencv_core -o "$out/image_fuzz"
"$out/image_fuzz" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 \
  -print_final_stats=1 "$out/corpus-images" 2>&1 | tail -n 12
