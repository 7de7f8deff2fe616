#!/usr/bin/env bash
# Runs clang-tidy (.clang-tidy) over the project's own sources: the libraries and programs, or
# only the files given. Exit 0 only when it reports nothing.
# The compile commands are clang's own (build-tidy/, configured here, never built): with GCC's
# commands clang cannot parse the link's coroutines (Boost.Asio decides per compiler whether
# co_await exists), and a file it cannot parse is a file it did not check. Parse errors count as
# findings for that reason.
# Slow the first time (it parses every translation unit, about as long as a build); after that
# only files whose preprocessed text changed are tidied again (scripts/tidy_run.py keeps each
# clean file's verdict, keyed as ccache keys an object), so CI runs it on every library and
# program (scripts/test.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-tidy -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ -DMLP_BUILD_TESTS=ON -DMLP_BUILD_BENCHMARKS=OFF >/dev/null
if [ $# -gt 0 ]; then
  files=("$@")
else
  mapfile -t files < <(git ls-files 'geometry/*.cc' 'calib/*.cc' 'probe_fw/*.cc' 'host/*.cc')
fi
python3 scripts/tidy_run.py build-tidy "${files[@]}"
