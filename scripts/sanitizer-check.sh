#!/usr/bin/env bash
# Builds everything (libraries, the shadefit CLI, every test, the libFuzzer harnesses) with clang,
# AddressSanitizer and UndefinedBehaviorSanitizer in build-sanitize/ (-DSHADEFIT_FUZZ=ON: every
# target instrumented, UB aborts, leaks are errors, libFuzzer's coverage in our code) and runs the
# whole CTest suite there, with the skip policy of the README's test command (CI=true: a skip no
# line of tests/ci-allowed-skips.txt allows fails). CI runs it, then fuzzes with the harnesses the
# same build made (scripts/fuzz-check.sh --build-dir build-sanitize --no-build). UBSan runs every
# check but four pointer checks in the Jet kernels (cmake/ShadefitHelpers.cmake); issue 14,
# docs/testing.md, "Bad input, sanitizers and fuzzing".
#   bash scripts/sanitizer-check.sh [--no-build] [ctest arguments...]
set -euo pipefail
cd "$(dirname "$0")/.."
build=1
if [ "${1:-}" = "--no-build" ]; then build=0; shift; fi
# The test command's packages (pdflatex, Chromium, Slurm, clang, ...): where .ci/run ran that
# command in a fresh root, this host has not installed them, and a test that needs one would skip.
bash scripts/bootstrap.sh packages
command -v clang++ >/dev/null ||
  { echo "sanitizer-check: error: clang++ not found (bootstrap.sh test installs clang)" >&2; exit 2; }
start=$(date +%s)
if [ "$build" = 1 ]; then
  # Release (-O3) keeps the suite's run time near the plain build's; -g1 gives the reports file
  # and line.
  cmake -S . -B build-sanitize -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang \
    -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_C_FLAGS=-g1 -DCMAKE_CXX_FLAGS=-g1 -DSHADEFIT_FUZZ=ON \
    -DSHADEFIT_BUILD_BENCH=OFF >/dev/null
  cmake --build build-sanitize -j"$(nproc)"
fi
built=$(date +%s)
echo "sanitizer-check: built in $(( built - start )) s"

# Every report fails the test that caused it: ASan and UBSan abort, LeakSanitizer runs at exit.
# The suppressions name leaks in system libraries only (tests/sanitizers/lsan.supp says why).
# intercept_tls_get_addr=0: clang 14's __tls_get_addr interceptor takes a dynamic TLS block that
# lies 16 bytes past a page boundary for one with glibc 2.19's header and records the two words
# before it as the block's range; since glibc 2.25 there is no header, the range is garbage, and
# LeakSanitizer's tracer faults scanning it ("Tracer caught signal 11", a fatal error, the test
# fails with no report). Off, dynamic TLS is not scanned for roots (static TLS still is); the
# whole suite is clean with it off (docs/testing.md, "LeakSanitizer's tracer crash").
export ASAN_OPTIONS=${ASAN_OPTIONS:-halt_on_error=1:detect_leaks=1:abort_on_error=1:strict_string_checks=1:intercept_tls_get_addr=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:abort_on_error=1:print_stacktrace=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/sanitizers/lsan.supp:print_suppressions=0}
# Left out (labels): python-only tests, where no C++ of ours runs, and the rerun tests, which run
# the quick study (already run here by report_quick_study) again to check shards, thread counts
# and SIGKILL; both cost CI minutes under the sanitizers and could not produce a report.
rc=0
(cd build-sanitize &&
  ctest -j"$(nproc)" --output-on-failure --timeout 1500 --output-junit ctest-junit.xml \
    -LE '^(python-only|rerun)$' "$@") ||
  rc=$?
/usr/bin/python3 scripts/check-skips.py build-sanitize/ctest-junit.xml tests/ci-allowed-skips.txt \
  "${CI:-}" || rc=1
echo "sanitizer-check: tests ran in $(( $(date +%s) - built )) s (total $(( $(date +%s) - start )) s)"
exit $rc
