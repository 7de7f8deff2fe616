#!/usr/bin/env bash
# Configures and builds mlprobe into build/ (Release with tests and benchmarks).
# Extra arguments are passed to cmake's configure step, e.g. -DMLP_SANITIZE=ON.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DMLP_BUILD_TESTS=ON \
  -DMLP_BUILD_BENCHMARKS=ON "$@" >/dev/null
# Two jobs: the machines here have 2 cores and 24 GiB; PCL translation units need ~1.5 GiB each.
cmake --build build -j "${MLP_JOBS:-2}"
