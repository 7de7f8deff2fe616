#!/usr/bin/env bash
# Runs clang-tidy (.clang-tidy) over the project's own sources: the libraries and programs, or
# only the files given. Exit 0 only when it reports nothing.
# The compile commands are clang's own (build-tidy/, configured here, never built): with GCC's
# commands clang cannot parse the link's coroutines (Boost.Asio decides per compiler whether
# co_await exists), and a file it cannot parse is a file it did not check. Parse errors count as
# findings for that reason.
# Slow (it parses every translation unit, about as long as a build): run by hand before a
# large change, not in every CI run.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build-tidy -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ -DMLP_BUILD_TESTS=ON -DMLP_BUILD_BENCHMARKS=OFF >/dev/null
if [ $# -gt 0 ]; then
  files=("$@")
else
  mapfile -t files < <(git ls-files 'geometry/*.cc' 'calib/*.cc' 'probe_fw/*.cc' 'host/*.cc')
fi
log=$(mktemp)
printf '%s\n' "${files[@]}" | xargs -P "${MLP_JOBS:-2}" -n 4 clang-tidy -p build-tidy --quiet \
  2>/dev/null >"$log" || true
count=$(grep -cE ': (warning|error):' "$log" || true)
grep -E ': (warning|error):' "$log" | sed 's/.*\[\(.*\)\]$/\1/' | sort | uniq -c | sort -rn || true
echo "tidy: ${count} findings in ${#files[@]} files (full report: $log)"
[ "$count" -eq 0 ]
