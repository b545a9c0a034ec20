#!/usr/bin/env bash
# Runs a command that must fail cleanly on bad input:
#   expect_error.sh <regex> <path that must not exist afterwards> <command...>
# Passes when the command exits non-zero, prints exactly one line on stderr, that line matches
# <regex> (which names the file and the field), and the output path does not exist.
set -u
regex=$1; output=$2; shift 2
rm -f "$output"
err=$("$@" 2>&1 >/dev/null); code=$?
lines=$(printf '%s\n' "$err" | grep -c .)
fail=0
[ "$code" -ne 0 ] || { echo "FAILED: exit code 0"; fail=1; }
[ "$lines" -eq 1 ] || { echo "FAILED: expected one line on stderr, got $lines"; fail=1; }
printf '%s\n' "$err" | grep -Eq -- "$regex" || { echo "FAILED: stderr does not match /$regex/"; fail=1; }
[ ! -e "$output" ] || { echo "FAILED: $output was written"; fail=1; }
echo "stderr: $err"
exit $fail
