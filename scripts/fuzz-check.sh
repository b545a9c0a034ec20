#!/usr/bin/env bash
# Builds the libFuzzer harnesses of tests/fuzz/ with clang (ASan + UBSan + libFuzzer coverage,
# build-fuzz/, or --build-dir) and fuzzes each for a while, starting from its committed seed
# corpus. Fails on any crash, leak, timeout, out-of-memory or sanitizer report; the input that
# caused it is left in <build dir>/artifacts/ (add it to tests/fuzz/corpus/<harness>/ with the
# fix: it then replays in CTest for ever). New inputs found go to <build dir>/fuzz-corpus/
# <harness>/, never to the committed corpus. CI runs it for 60 s a harness with a fixed seed on
# the harnesses scripts/sanitizer-check.sh built (issue 14; docs/testing.md).
#   bash scripts/fuzz-check.sh [--seconds N] [--only NAME[,NAME...]] [--jobs N] [--seed N]
#                              [--build-dir DIR] [--no-build]
# --seed N: libFuzzer's seed (default: a new one each run); a fixed one makes a run repeatable.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=60
jobs=$(nproc)
only=""
build=1
dir=build-fuzz
seed=""
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    --build-dir) dir=${2%/}; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    -h | --help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "fuzz-check: error: unknown option $1 (see --help)" >&2; exit 2 ;;
  esac
done
[[ "$jobs" =~ ^[1-9][0-9]*$ ]] ||
  { echo "fuzz-check: error: --jobs must be a positive whole number, not '$jobs'" >&2; exit 2; }
[ -z "$seed" ] || [[ "$seed" =~ ^[1-9][0-9]*$ ]] ||
  { echo "fuzz-check: error: --seed must be a positive whole number, not '$seed'" >&2; exit 2; }
harnesses=(scene study merl neural_brdf sidecar image)
if [ -n "$only" ]; then IFS=, read -r -a harnesses <<< "$only"; fi
command -v clang++ >/dev/null ||
  { echo "fuzz-check: error: clang++ not found (bootstrap.sh test installs clang)" >&2; exit 2; }

start=$(date +%s)
if [ "$build" = 1 ]; then
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DSHADEFIT_FUZZ=ON \
    -DSHADEFIT_BUILD_BENCH=OFF >/dev/null
  cmake --build "$dir" -j"$(nproc)" --target "${harnesses[@]/#/fuzz_}"
fi
for h in "${harnesses[@]}"; do
  [ -x "$dir/tests/fuzz/fuzz_$h" ] || [ "$build" = 1 ] || {
    echo "fuzz-check: error: $dir/tests/fuzz/fuzz_$h not built (configure with -DSHADEFIT_FUZZ=ON)" >&2
    exit 2
  }
done
echo "fuzz-check: built in $(( $(date +%s) - start )) s"

# Leaks and UB are errors; libFuzzer turns a sanitizer report into a crash with its input saved.
# intercept_tls_get_addr=0: see scripts/sanitizer-check.sh (clang 14's garbage dynamic-TLS ranges).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1:intercept_tls_get_addr=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/sanitizers/lsan.supp:print_suppressions=0}
mkdir -p "$dir/artifacts"
# Fuzzes harness $1 for $seconds s; writes its one-line summary (and, on failure, the report's
# key lines) to $dir/fuzz-$1.summary and its status to $dir/fuzz-$1.status.
fuzz_one() {
  local h=$1 work=$dir/fuzz-corpus/$1 log=$dir/fuzz-$1.log t0 status limit
  mkdir -p "$work"
  t0=$(date +%s)
  # One worker per harness. -timeout: a single input taking longer than 10 s is a hang, except
  # for MERL, whose full-size inputs write and read a 35 MB table (about 1 s of CPU; 13 s was
  # seen on a loaded machine); -rss_limit_mb: a reader that allocates 2 GiB for a small file is
  # a bug.
  limit=10
  [ "$h" = merl ] && limit=60
  if "$dir/tests/fuzz/fuzz_$h" "$work" "tests/fuzz/corpus/$h" -max_total_time="$seconds" \
      ${seed:+-seed="$seed"} \
      -timeout="$limit" -rss_limit_mb=2048 -print_final_stats=1 \
      -artifact_prefix="$dir/artifacts/$h-" >"$log" 2>&1; then
    status=ok
  else
    status=FAILED
  fi
  local runs rate cov ft
  runs=$(grep -m1 -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  rate=$(grep -m1 -o 'stat::average_exec_per_sec: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo "?")
  ft=$(grep -o 'ft: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo "?")
  {
    echo "fuzz-check: $h: $status, $runs runs in $(( $(date +%s) - t0 )) s ($rate/s), cov $cov, ft $ft, corpus $(ls "$work" | wc -l) new (log $log)"
    if [ "$status" = FAILED ]; then grep -E 'ERROR|SUMMARY|Test unit written|==[0-9]+==' "$log" | head -20 || true; fi
  } >"$dir/fuzz-$h.summary"
  echo "$status" >"$dir/fuzz-$h.status"
}
# As many harnesses at once as there are cores (each fuzzes on one): 6 x 60 s take 3 minutes on
# 2 cores, not 6. Summaries are printed in harness order.
failed=()
for ((i = 0; i < ${#harnesses[@]}; i += jobs)); do
  batch=("${harnesses[@]:i:jobs}")
  for h in "${batch[@]}"; do fuzz_one "$h" & done
  wait
  for h in "${batch[@]}"; do
    cat "$dir/fuzz-$h.summary"
    [ "$(cat "$dir/fuzz-$h.status")" = ok ] || failed+=("$h")
  done
done
echo "fuzz-check: total $(( $(date +%s) - start )) s"
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz-check: FAILED: ${failed[*]} (inputs in $dir/artifacts/)" >&2
  exit 1
fi
