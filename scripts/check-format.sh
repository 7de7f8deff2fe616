#!/usr/bin/env bash
# Every C++ file of the project is clang-format clean (the style in .clang-format).
set -euo pipefail
cd "$(dirname "$0")/.."
files=$(git ls-files '*.cc' '*.h' 2>/dev/null || find . -name '*.cc' -o -name '*.h' | grep -v '^./build')
clang-format --dry-run --Werror $files
echo "check-format: $(echo "$files" | wc -w) files clean"
