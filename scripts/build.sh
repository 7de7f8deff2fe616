#!/usr/bin/env bash
# Configures and builds mlprobe into build/ (Release with tests and benchmarks), through ccache
# when it is there (scripts/build-env.sh). Extra arguments go to cmake's configure step.
# MLP_BUILD_DIR names another build folder (scripts/sanitize.sh builds build-sanitize).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/build-env.sh
dir=${MLP_BUILD_DIR:-build}
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DMLP_BUILD_TESTS=ON \
  -DMLP_BUILD_BENCHMARKS=ON "${mlp_launcher[@]}" "$@" >/dev/null
# Two jobs: the machines here have 2 cores and 24 GiB; PCL translation units need ~1.5 GiB each.
cmake --build "$dir" -j "${MLP_JOBS:-2}"
