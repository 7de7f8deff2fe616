#!/usr/bin/env bash
# Runs clang-tidy (.clang-tidy) over the project's own sources with build/'s compile commands:
# the libraries and programs, or only the files given. Exit 0 only when it reports nothing.
# Slow (it parses every translation unit, about as long as a build): run by hand before a
# large change, not in every CI run.
set -euo pipefail
cd "$(dirname "$0")/.."
[ -f build/compile_commands.json ] || { echo "tidy: configure build/ first (scripts/build.sh)" >&2; exit 2; }
if [ $# -gt 0 ]; then
  files=("$@")
else
  mapfile -t files < <(git ls-files 'geometry/*.cc' 'calib/*.cc' 'probe_fw/*.cc' 'host/*.cc')
fi
log=$(mktemp)
printf '%s\n' "${files[@]}" | xargs -P "${MLP_JOBS:-2}" -n 4 clang-tidy -p build --quiet \
  --extra-arg=-Wno-sign-conversion --extra-arg=-Wno-unknown-warning-option \
  2>/dev/null >"$log" || true
count=$(grep -c ': warning:' "$log" || true)
grep ': warning:' "$log" | sed 's/.*\[\(.*\)\]$/\1/' | sort | uniq -c | sort -rn || true
echo "tidy: ${count} findings in ${#files[@]} files (full report: $log)"
[ "$count" -eq 0 ]
