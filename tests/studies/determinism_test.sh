#!/usr/bin/env bash
# Byte-identical reruns (docs/studies.md, "Determinism"; docs/cluster.md): the quick study run
# with -j 2, again with -j 1, and as 2 shards run side by side and merged, must give the same
# bytes in every result file: results.csv, the job JSONs, the probes' JSON, the report's tables
# and verdicts.json. Only what records time, host or run shape may differ (the list below).
# Then the merge's refusals: a missing shard manifest and an unfinished job each stop it with
# one line naming the file, exit non-zero, and leave no results.csv.
#
#   determinism_test.sh SHADEFIT STUDY.toml WORKDIR
set -euo pipefail
shadefit=$1 study=$2 work=$3
fail() { echo "FAILED: $*"; exit 1; }
rm -rf "$work"
mkdir -p "$work"

run() { "$shadefit" study run "$study" --quick -q "$@" >/dev/null; }
run -j 2 -o "$work/a"
run -j 1 -o "$work/b"
run --shard 1/2 -j 1 -o "$work/c" &
shard1=$!
run --shard 2/2 -j 1 -o "$work/c"
wait "$shard1" || fail "shard 1/2 failed"
[ ! -e "$work/c/"*/results.csv ] || fail "a shard wrote results.csv (only the merge may)"
name=$(basename "$(ls -d "$work"/a/*/)")
"$shadefit" study merge -q "$work/c/$name" >/dev/null

# Files that record when, where or how a run ran, not what it found.
not_results='^(study\.log|provenance\.json|timings\.csv|shards/.*|jobs/.*\.timing\.json|report/figures/.*\.hash)$'  # .hash: the report's figure cache (report/figure_cache.py), whose keys cover the output folder's paths
list() {
  (cd "$1" && find . -type f ! -name '.*' | sed 's|^\./||' | grep -Ev "$not_results" | sort)
}
a="$work/a/$name"
list "$a" >"$work/files.a"
grep -q '^results.csv$' "$work/files.a" || fail "run a wrote no results.csv"
grep -q '^report/tables/.*\.tex$' "$work/files.a" || fail "run a wrote no LaTeX tables"
grep -q '^jobs/probe\..*\.json$' "$work/files.a" || fail "run a wrote no probe job"
for other in b c; do
  list "$work/$other/$name" >"$work/files.$other"
  diff -u "$work/files.a" "$work/files.$other" >/dev/null ||
    fail "run $other wrote other files than run a: $(diff "$work/files.a" "$work/files.$other" | head -n 4 | tr '\n' ' ')"
  while IFS= read -r rel; do
    cmp -s "$a/$rel" "$work/$other/$name/$rel" || fail "$rel differs between run a (-j 2) and run $other"
  done <"$work/files.a"
done
echo "identical: $(wc -l <"$work/files.a") files across -j 2, -j 1 and 2 merged shards"

# The merge refuses an incomplete sharded run, with one line and no results.
refuse() {  # refuse <what> <expected text> <study dir>
  local out rc=0
  out=$("$shadefit" study merge -q "$3" 2>&1 >/dev/null) || rc=$?
  [ "$rc" -ne 0 ] || fail "merge accepted $1"
  [ "$(printf '%s\n' "$out" | wc -l)" -eq 1 ] || fail "merge of $1 printed more than one line: $out"
  printf '%s\n' "$out" | grep -qF -- "$2" || fail "merge of $1 said '$out', want '$2'"
  [ ! -e "$3/results.csv" ] || fail "merge of $1 left results.csv"
  echo "refused $1: $out"
}
cp -a "$work/c" "$work/d"
rm -f "$work/d/$name/results.csv" "$work/d/$name/shards/2-of-2.json"
refuse "a missing shard" "2-of-2.json: missing: shard 2/2 has not finished" "$work/d/$name"
cp -a "$work/c" "$work/e"
rm -f "$work/e/$name/results.csv"
victim=$(ls "$work/e/$name/jobs/" | grep -v timing | grep '^fit\.' | head -n 1)
rm -f "$work/e/$name/jobs/$victim"
refuse "a missing job" "not done or out of date (first: ${victim%.json})" "$work/e/$name"
