#!/usr/bin/env bash
# Runs the whole test suite as CI does (ctest -j2) while two CPU hogs keep both cores busy,
# RUNS times in a row (default 3): a test that holds only on an idle machine fails here.
# Usage: bash scripts/test-under-load.sh [RUNS]   (builds first, without the load)
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-3}
bash scripts/build.sh
hogs=()
stop_hogs() { kill "${hogs[@]}" 2>/dev/null || true; }
trap stop_hogs EXIT
for _ in 1 2; do
  bash -c 'while :; do :; done' &
  hogs+=($!)
done
echo "test-under-load: 2 CPU hogs running (pids ${hogs[*]}), $runs runs of the suite"
for run in $(seq 1 "$runs"); do
  start=$(date +%s)
  if ! ctest --test-dir build --output-on-failure -j 2 --timeout 600 >"build/under-load-$run.log" 2>&1; then
    grep -E "tests passed|\(Failed\)|\(Timeout\)|\*\*\*" "build/under-load-$run.log" | tail -20 >&2
    echo "test-under-load: run $run FAILED after $(($(date +%s) - start)) s (build/under-load-$run.log)" >&2
    exit 1
  fi
  echo "test-under-load: run $run passed in $(($(date +%s) - start)) s ($(grep -o '[0-9]*% tests passed.*' "build/under-load-$run.log"))"
done
echo "test-under-load: all $runs runs passed under load"
