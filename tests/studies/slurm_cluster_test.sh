#!/usr/bin/env bash
# A study on a real Slurm cluster (docs/cluster.md): starts a one-node cluster on localhost
# (munged, slurmctld, slurmd from Debian's slurm-wlm and munge, configured here in a temporary
# folder, loopback only, ports chosen free), writes the sbatch scripts with
# `shadefit study slurm --array 2`, submits them with the command it prints (a 2-task job array
# and a merge job that depends on it), waits, and checks that the merged tables equal a local
# single-machine run of the same study byte for byte.
#
#   slurm_cluster_test.sh SHADEFIT STUDY.toml WORKDIR
#
# Exit 77 (CTest SKIP_RETURN_CODE) with a line saying why when Slurm is not installed or cannot
# be started here.
set -euo pipefail
shadefit=$1 study=$2 work=$3
skip() { echo "SKIP: $*"; exit 77; }
fail() { echo "FAILED: $*"; exit 1; }

rm -rf "$work"
mkdir -p "$work"

# A bad option is one line naming it, a non-zero exit and no scripts (no cluster needed).
if "$shadefit" study slurm "$study" --merge-cpus -1 -o "$work/bad" 2>"$work/bad.err"; then
  fail "--merge-cpus -1 was accepted"
fi
grep -q -- "--merge-cpus" "$work/bad.err" || fail "the error does not name --merge-cpus: $(cat "$work/bad.err")"
[ ! -e "$work/bad" ] || [ -z "$(find "$work/bad" -name '*.sbatch')" ] || fail "scripts written for a bad option"
tmp=$(mktemp -d "$work/cluster.XXXXXX")
# shellcheck source=../../scripts/local-slurm.sh
source "$(dirname "$0")/../../scripts/local-slurm.sh"
trap 'local_slurm_stop "$tmp"' EXIT
rc=0
local_slurm_start "$tmp" 2>"$tmp/why" || rc=$?
[ "$rc" -eq 0 ] || skip "$(cat "$tmp/why")"

# The scripts, from the command a user types on a login node; then its one submit line.
# The merge gets the node's CPUs for its report's drawing processes.
merge_cpus=$(nproc)
submit=$("$shadefit" study slurm "$study" --quick --array 2 --cpus 1 --merge-cpus "$merge_cpus" \
  --time 00:20:00 --partition local -o "$work/cluster")
echo "submit: $submit"
grep -q -- '--array=1-2' "$work"/cluster/*/slurm/shards.sbatch || fail "no --array=1-2 in shards.sbatch"
grep -q -- '--cpus-per-task=1$' "$work"/cluster/*/slurm/shards.sbatch || fail "shards.sbatch: not 1 CPU per task"
grep -q -- "--cpus-per-task=$merge_cpus\$" "$work"/cluster/*/slurm/merge.sbatch ||
  fail "merge.sbatch: not --cpus-per-task=$merge_cpus"
t0=$(date +%s)
bash -c "$submit" >"$tmp/submitted" || fail "sbatch failed: $(cat "$tmp/submitted")"
echo "sbatch: $(cat "$tmp/submitted") (the merge, after the array)"
local_slurm_wait 600 || fail "jobs still queued after 600 s: $(squeue -h)"
echo "slurm: array and merge finished in $(( $(date +%s) - t0 )) s"

dir=$(ls -d "$work"/cluster/*/)
dir=${dir%/}
for f in "$dir"/slurm/shard-1.out "$dir"/slurm/shard-2.out "$dir"/slurm/merge.out; do
  [ -f "$f" ] || fail "$f missing (the job did not run)"
done
grep -q "(shard 1-of-2)" "$dir/slurm/shard-1.out" || fail "shard 1 did not run as 1-of-2: $(tail -n 3 "$dir/slurm/shard-1.out")"
grep -q "(shard 2-of-2)" "$dir/slurm/shard-2.out" || fail "shard 2 did not run as 2-of-2"
grep -q "(merge)" "$dir/slurm/merge.out" || fail "the merge did not run: $(tail -n 3 "$dir/slurm/merge.out")"
grep -q "0 ran, .* unchanged" "$dir/slurm/merge.out" || fail "the merge ran jobs itself"
for i in 1 2; do
  n=$(grep -c '"id"' "$dir/shards/$i-of-2.json" || true)
  [ "$n" -ge 2 ] || fail "shard $i ran fewer than 2 jobs ($dir/shards/$i-of-2.json)"
done
[ -f "$dir/report/index.html" ] || fail "the merge made no report: $(tail -n 3 "$dir/slurm/merge.out")"

# The same study on this machine, in one process.
"$shadefit" study run "$study" --quick -q -j 2 -o "$work/local" >/dev/null
local_dir=$(ls -d "$work"/local/*/)
local_dir=${local_dir%/}
compared=0
while IFS= read -r rel; do
  cmp -s "$local_dir/$rel" "$dir/$rel" || fail "$rel differs between the merged and the local run"
  compared=$((compared + 1))
done < <(cd "$local_dir" && find results.csv report/tables report/verdicts.json jobs \
           -type f \( -name '*.csv' -o -name '*.tex' -o -name '*.json' \) ! -name '*.timing.json' |
           sort)
[ "$compared" -ge 10 ] || fail "only $compared files compared"
echo "merged == local: $compared files byte-identical (results.csv, report/tables, verdicts.json, jobs/*.json)"
