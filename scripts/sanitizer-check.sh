#!/usr/bin/env bash
# Builds everything (libraries, the shadefit CLI, every test) with AddressSanitizer and
# UndefinedBehaviorSanitizer in build-asan/ (-DSHADEFIT_SANITIZE=ON: UB aborts, leaks are
# errors) and runs the CTest suite there. CI runs it (issue 14; docs/testing.md, "Sanitizers").
#   bash scripts/sanitizer-check.sh [--no-build] [ctest arguments...]
set -euo pipefail
cd "$(dirname "$0")/.."
build=1
if [ "${1:-}" = "--no-build" ]; then build=0; shift; fi
start=$(date +%s)
if [ "$build" = 1 ]; then
  # Release (-O3) keeps the suite's run time near the plain build's; -g1 gives ASan's reports
  # file and line.
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_FLAGS=-g1 \
    -DCMAKE_CXX_FLAGS=-g1 -DSHADEFIT_SANITIZE=ON -DSHADEFIT_BUILD_BENCH=OFF >/dev/null
  cmake --build build-asan -j"$(nproc)"
fi
built=$(date +%s)
echo "sanitizer-check: built in $(( built - start )) s"

# Every report fails the test that caused it: ASan and UBSan abort, LeakSanitizer runs at exit.
# The suppressions name leaks in system libraries only (tests/sanitizers/lsan.supp says why).
export ASAN_OPTIONS=${ASAN_OPTIONS:-halt_on_error=1:detect_leaks=1:abort_on_error=1:strict_string_checks=1:detect_stack_use_after_return=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/sanitizers/lsan.supp:print_suppressions=0}
ctest --test-dir build-asan -j"$(nproc)" --output-on-failure --timeout 1500 "$@"
echo "sanitizer-check: tests ran in $(( $(date +%s) - built )) s (total $(( $(date +%s) - start )) s)"
