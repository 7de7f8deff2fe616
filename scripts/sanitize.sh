#!/usr/bin/env bash
# The suite under AddressSanitizer and UndefinedBehaviorSanitizer (GCC's, as the release build:
# the same compiler draws the same seeded test data). Builds build-sanitize (Release, -g1 for
# line numbers in reports) and runs every test that takes under MLP_SANITIZE_MAX_S seconds (10)
# in the release run whose timings ctest kept (build/Testing/Temporary/CTestCostData.txt): the
# few long accuracy sweeps (23 tests, 90 % of the suite's time) go through the same code as the
# short tests, and run several times slower under the sanitizers (ASan's documented slowdown is
# about 2x; not yet measured here at -O3; at -O1 with clang one sweep ran over 15x slower). Also left out: the
# arm64 cross build, the libFuzzer run and the format check, which are not this build's code.
# A report stops the test (-fno-sanitize-recover=all) and fails it. Exit code: ctest's.
# Usage: bash scripts/sanitize.sh [--all]   (--all: every test, however long)
set -euo pipefail
cd "$(dirname "$0")/.."
MLP_BUILD_DIR=build-sanitize bash scripts/build.sh -DMLP_SANITIZE=ON -DMLP_BUILD_BENCHMARKS=OFF \
  -DCMAKE_CXX_FLAGS=-g1
export ASAN_OPTIONS="detect_leaks=1:strict_string_checks=1:detect_stack_use_after_return=1"
export UBSAN_OPTIONS="print_stacktrace=1"
exclude='^(portability/|fuzz/|style/)'
costs=build/Testing/Temporary/CTestCostData.txt
if [ "${1:-}" != "--all" ] && [ -f "$costs" ]; then
  # Lines "<name> <runs> <seconds>"; a name is a regex once its special characters are escaped.
  long=$(awk -v max="${MLP_SANITIZE_MAX_S:-10}" 'NF == 3 && $3 >= max { print $1 }' "$costs" |
    sed -e 's/[][\.*^$+?(){}|]/\\&/g' | paste -sd'|' -)
  [ -n "$long" ] && exclude="$exclude|^($long)\$"
  echo "sanitize: $(awk -v max="${MLP_SANITIZE_MAX_S:-10}" 'NF == 3 && $3 >= max' "$costs" |
    wc -l) tests over ${MLP_SANITIZE_MAX_S:-10} s in the release run are left out"
fi
ctest --test-dir build-sanitize --output-on-failure -j 2 --timeout 900 -E "$exclude"
