#!/usr/bin/env bash
# Installs dependencies, builds everything and runs every test (the README's test command):
# the release build's whole suite (GCC), then again under clang's ASan and UBSan every test
# that took under 15 s in that release run (scripts/sanitize.sh --quick; 547 of 587 on
# 2026-11-28). The longer ones are end-to-end and accuracy runs through code the shorter
# sanitized tests also run; sanitized they take over 37 minutes of CPU (19 on 2 cores), and the brief
# keeps CI under 30 minutes on 2 cores. `bash scripts/sanitize.sh` runs all but three of them
# sanitized, `--all` every one: before a change to the renderer, the fits or the service.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j 2 --timeout 600
MLP_SANITIZE_MAX_S=15 bash scripts/sanitize.sh --quick
