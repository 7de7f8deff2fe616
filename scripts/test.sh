#!/usr/bin/env bash
# Installs dependencies, builds everything and runs every test (the README's test command):
# the release build's whole suite (GCC), then the suite again under clang's ASan and UBSan
# (scripts/sanitize.sh: every test but three long sweeps, which --all adds).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j 2 --timeout 600
bash scripts/sanitize.sh
