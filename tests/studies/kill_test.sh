#!/usr/bin/env bash
# kill -9 anywhere (docs/studies.md, "Jobs, resuming and interruption"): the quick study is
# killed with SIGKILL at several points, and after each kill
#   - every file under its final name is complete: the same bytes as in an uninterrupted run
#     (results are deterministic, so a partial file cannot hide);
#   - the rerun resumes: it runs exactly the jobs that had no JSON, and skips the rest;
#   - after the rerun no temporary file is left, and every result file, table and figure equals
#     the uninterrupted run's.
# Kill points: during a fit (SHADEFIT_KILL_AT=fit:3, after the third fit's solve), while writing
# a result (result:3, the third job's JSON half written to its temporary), and while writing the
# report (the report's Python kills the process group at its 5th file rename, through
# SHADEFIT_PYTHON; the report is the last step, after results.csv).
#
#   kill_test.sh SHADEFIT STUDY.toml WORKDIR
set -euo pipefail
shadefit=$1 study=$2 work=$3
fail() { echo "FAILED: $*"; exit 1; }
rm -rf "$work"
mkdir -p "$work"
run() { "$shadefit" study run "$study" --quick -q -j 2 "$@"; }

run -o "$work/ref" >/dev/null
name=$(basename "$(ls -d "$work"/ref/*/)")
ref="$work/ref/$name"
# What records when, where or how a run ran, not what it found (docs/studies.md, "Determinism").
not_results='^(study\.log|provenance\.json|timings\.csv|shards/.*|jobs/.*\.timing\.json|report/figures/.*\.hash)$'  # .hash: the report's figure cache (report/figure_cache.py), whose keys cover the output folder's paths
results() { (cd "$1" && find . -type f ! -name '.*' | sed 's|^\./||' | grep -Ev "$not_results" | sort); }
total_jobs=$(ls "$ref/jobs" | grep -vc timing)

# A Python that runs the report and kills the whole process group at the report's n-th rename.
cat >"$work/killing-python" <<'EOF'
#!/bin/sh
exec /usr/bin/python3 -c '
import os, runpy, signal, sys
limit, seen = int(os.environ["KILL_AT_RENAME"]), [0]
def hook(event, args):
    if event == "os.rename":
        seen[0] += 1
        if seen[0] == limit:
            os.killpg(0, signal.SIGKILL)
sys.addaudithook(hook)
sys.argv = sys.argv[1:]
runpy.run_path(sys.argv[0], run_name="__main__")
' "$@"
EOF
chmod +x "$work/killing-python"

for point in fit:3 result:3 report:5; do
  out="$work/${point%%:*}"
  rc=0
  if [ "${point%%:*}" = report ]; then
    # setsid: the killed process group is the study's, not this script's.
    KILL_AT_RENAME=${point#*:} SHADEFIT_PYTHON="$work/killing-python" \
      setsid "$shadefit" study run "$study" --quick -q -j 2 -o "$out" >/dev/null 2>&1 &
    group=$!
    wait "$group" || rc=$?
    # The report's Python dies with the group; let it be gone (or a zombie) before the rerun.
    for _ in $(seq 50); do
      pgrep -g "$group" >/dev/null || break
      sleep 0.1
    done
  else
    SHADEFIT_KILL_AT=$point run -o "$out" >/dev/null 2>&1 || rc=$?
  fi
  [ "$rc" -eq 137 ] || fail "kill at $point: exit status $rc, want 137 (SIGKILL)"
  dir="$out/$name"
  # Nothing partial under a final name.
  while IFS= read -r rel; do
    [ -f "$ref/$rel" ] || fail "kill at $point left $rel, which an uninterrupted run never writes"
    cmp -s "$ref/$rel" "$dir/$rel" || fail "kill at $point left $rel incomplete or different"
  done < <(results "$dir")
  done_jobs=$(ls "$dir/jobs" | grep -v timing | grep -c '\.json$' || true)
  temporaries=$(find "$dir" -name '.*' -type f | wc -l)
  # The rerun resumes.
  run -o "$out" >/dev/null || fail "rerun after the kill at $point failed"
  summary=$(grep -E 'study .*: [0-9]+ ran, ' "$dir/study.log" | tail -n 1 | sed -E 's/.*(study )/\1/')
  ran=$(sed -E 's/.*: ([0-9]+) ran, ([0-9]+) unchanged.*/\1/' <<<"$summary")
  unchanged=$(sed -E 's/.*: ([0-9]+) ran, ([0-9]+) unchanged.*/\2/' <<<"$summary")
  [ "$unchanged" -eq "$done_jobs" ] && [ "$ran" -eq $((total_jobs - done_jobs)) ] ||
    fail "after the kill at $point ($done_jobs of $total_jobs jobs done) the rerun said: $summary"
  left=$(find "$dir" -name '.*' -type f)
  [ -z "$left" ] || fail "the rerun after the kill at $point left temporaries: $left"
  diff <(results "$ref") <(results "$dir") >/dev/null || fail "after the kill at $point and a rerun, other files than an uninterrupted run's"
  while IFS= read -r rel; do
    cmp -s "$ref/$rel" "$dir/$rel" || fail "after the kill at $point and a rerun, $rel differs"
  done < <(results "$ref")
  echo "killed at $point: $done_jobs/$total_jobs jobs done, $temporaries temporaries; rerun: $summary; $(results "$ref" | wc -l) files identical"
done
