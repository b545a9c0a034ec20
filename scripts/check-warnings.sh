#!/usr/bin/env bash
# Fails when a build log holds a compiler warning. Every compile step in our build compiles our
# own code, and dependencies' headers come in as system headers (no warnings of their own), so any
# "warning:" in the log is ours, including the ones GCC reports inside a standard header on behalf
# of our code ("In function ..., inlined from ... at render/src/...").
# -Werror stays off (a newer compiler's new warning must not break a user's build); CI runs this
# on the log of a full build of a fresh clone instead.
#   bash scripts/check-warnings.sh BUILD_LOG
set -euo pipefail
log=${1:?usage: check-warnings.sh BUILD_LOG}
[ -f "$log" ] || { echo "check-warnings: error: $log: build log not found" >&2; exit 2; }
grep -q -E '^\[[0-9]+/[0-9]+\] ' "$log" ||
  { echo "check-warnings: error: $log: no build step in the log (nothing was compiled?)" >&2; exit 2; }
n=$(grep -c -E '(: warning: |^cc1plus: warning: )' "$log" || true)
if [ "$n" -gt 0 ]; then
  echo "check-warnings: $n compiler warning(s) in $log (fix them; do not silence them):" >&2
  grep -E '(: warning: |^cc1plus: warning: )' "$log" | sort | uniq -c | sort -rn | head -n 40 >&2
  exit 1
fi
echo "check-warnings: no compiler warning in $(grep -c -E '^\[[0-9]+/[0-9]+\] Building' "$log") compile steps"
