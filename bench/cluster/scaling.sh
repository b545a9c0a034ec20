#!/usr/bin/env bash
# Shard scaling on a one-node Slurm cluster on this machine (docs/cluster.md, BENCHMARKS.md).
#
#   bash bench/cluster/scaling.sh [STUDY.toml] [SHADEFIT]
#
# Prints, for the same study:
#   - `study run -j CPUS` directly (no Slurm): the baseline;
#   - through Slurm with 1, 2 and 4 shards (`study slurm --array N --cpus C --merge-cpus CPUS`,
#     C = CPUS / N, at least 1): wall time from submission until the merge (with its report, on
#     every CPU) has finished;
#   - the Slurm path's per-job overhead: an array of 8 tasks that run `true`, and a shard whose
#     jobs are all done (study loading, input hashing, manifest).
# Each run starts from an empty output folder; the measured references are rendered by the
# shards, as on a cluster. Needs slurm-wlm and munge (scripts/bootstrap.sh test installs them).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/../.." && pwd)
study=${1:-$here/scaling_study.toml}
shadefit=${2:-$repo/build/studies/shadefit}
cpus=$(nproc)
work=$(mktemp -d /tmp/shadefit-scaling.XXXXXX)
source "$repo/scripts/local-slurm.sh"
trap 'local_slurm_stop "$work/cluster"; rm -rf "$work"' EXIT
local_slurm_start "$work/cluster"

now() { date +%s.%N; }
since() { echo "$(now) - $1" | bc -l | xargs printf '%.1f'; }

echo "machine: $(nproc) CPUs, load $(cut -d' ' -f1-3 /proc/loadavg), $(uname -r)"
echo "study: $study"
t=$(now)
"$shadefit" study run "$study" -q -j "$cpus" -o "$work/direct" >/dev/null
direct=$(since "$t")
echo "direct   study run -j $cpus: ${direct} s"
for n in 1 2 4; do
  c=$(( cpus / n )); [ "$c" -ge 1 ] || c=1
  submit=$("$shadefit" study slurm "$study" --array "$n" --cpus "$c" --merge-cpus "$cpus" \
    -o "$work/s$n" 2>/dev/null)
  t=$(now)
  bash -c "$submit" >/dev/null
  local_slurm_wait 3600
  wall=$(since "$t")
  dir=$(ls -d "$work/s$n"/*/)
  grep -q "(merge)" "$dir/slurm/merge.out" || { echo "merge of $n shards failed:"; tail -n 5 "$dir/slurm/merge.out"; exit 1; }
  cmp -s "$work/direct/$(basename "$dir")/results.csv" "$dir/results.csv" ||
    { echo "results.csv of $n shards differs from the direct run"; exit 1; }
  echo "slurm    $n shard(s) x $c CPU(s): ${wall} s  (x$(echo "$wall / $direct" | bc -l | xargs printf '%.2f') the direct run; results.csv identical)"
done

# Per-job overhead: scheduling alone, then a shard with nothing left to do.
printf '#!/bin/bash\n#SBATCH --array=1-8\n#SBATCH --cpus-per-task=1\n#SBATCH --output=/dev/null\ntrue\n' >"$work/true.sbatch"
t=$(now)
sbatch --parsable "$work/true.sbatch" >/dev/null
local_slurm_wait 600
empty=$(since "$t")
echo "overhead 8 array tasks running 'true': ${empty} s ($(echo "$empty / 8" | bc -l | xargs printf '%.2f') s per task, $cpus at a time)"
t=$(now)
"$shadefit" study run "$study" -q -o "$work/s2" --shard 1/2 --no-report >/dev/null
echo "overhead a shard whose jobs are all done: $(since "$t") s"
