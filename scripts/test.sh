#!/usr/bin/env bash
# Installs dependencies, builds everything and runs every test (the README's test command).
# The sanitized run (scripts/sanitize.sh) is not part of it yet: see docs/DEVELOPING.md.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
ctest --test-dir build --output-on-failure -j 2 --timeout 600
