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

for tool in munged mungekey slurmctld slurmd sbatch squeue scancel sinfo; do
  command -v "$tool" >/dev/null 2>&1 ||
    skip "Slurm is not installed: '$tool' not found (apt-get install slurm-wlm munge)"
done

rm -rf "$work"
mkdir -p "$work"
tmp=$(mktemp -d "$work/cluster.XXXXXX")
mkdir -p "$tmp/state" "$tmp/spool" "$tmp/log"
export SLURM_CONF=$tmp/slurm.conf
unset SLURM_JOB_ID SLURM_ARRAY_TASK_ID  # When the suite itself runs inside a Slurm job.

cleanup() {
  scancel --quiet --user="$(id -un)" >/dev/null 2>&1 || true
  for pidfile in "$tmp/slurmd.pid" "$tmp/slurmctld.pid" "$tmp/munged.pid"; do
    [ -s "$pidfile" ] && kill "$(cat "$pidfile")" 2>/dev/null || true
  done
  sleep 1
  for pidfile in "$tmp/slurmd.pid" "$tmp/slurmctld.pid" "$tmp/munged.pid"; do
    [ -s "$pidfile" ] && kill -9 "$(cat "$pidfile")" 2>/dev/null || true
  done
}
trap cleanup EXIT

free_port() {
  /usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'
}
ctl_port=$(free_port)
d_port=$(free_port)
while [ "$d_port" = "$ctl_port" ]; do d_port=$(free_port); done
user=$(id -un)
cpus=$(nproc)

mungekey --create --keyfile="$tmp/munge.key" --force >/dev/null 2>&1 ||
  skip "mungekey could not create a key in $tmp"
chmod 600 "$tmp/munge.key"
munged --force --socket="$tmp/munge.sock" --key-file="$tmp/munge.key" \
  --log-file="$tmp/log/munged.log" --pid-file="$tmp/munged.pid" --seed-file="$tmp/munged.seed" ||
  skip "munged could not start: $(tail -n 1 "$tmp/log/munged.log" 2>/dev/null)"

cat >"$SLURM_CONF" <<EOF
ClusterName=shadefit-test
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=$user
SlurmdUser=$user
SlurmctldPort=$ctl_port
SlurmdPort=$d_port
AuthType=auth/munge
AuthInfo=socket=$tmp/munge.sock
CredType=cred/munge
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
SlurmdTimeout=60
InactiveLimit=0
MinJobAge=600
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF

slurmctld -f "$SLURM_CONF" -i >/dev/null 2>&1 ||
  skip "slurmctld could not start: $(tail -n 1 "$tmp/log/slurmctld.log" 2>/dev/null)"
slurmd -f "$SLURM_CONF" -N localhost >/dev/null 2>&1 ||
  skip "slurmd could not start: $(tail -n 1 "$tmp/log/slurmd.log" 2>/dev/null)"
for _ in $(seq 60); do
  state=$(sinfo -h -N -o %t 2>/dev/null || true)
  [ "$state" = idle ] && break
  sleep 0.5
done
[ "$state" = idle ] ||
  skip "the local Slurm node did not come up (state '$state'): $(tail -n 1 "$tmp/log/slurmd.log")"
echo "slurm: one-node cluster up on 127.0.0.1:$ctl_port ($cpus CPUs)"

# The scripts, from the command a user types on a login node; then its one submit line.
submit=$("$shadefit" study slurm "$study" --quick --array 2 --cpus 1 --time 00:20:00 \
  --partition local -o "$work/cluster")
echo "submit: $submit"
grep -q -- '--array=1-2' "$work"/cluster/*/slurm/shards.sbatch || fail "no --array=1-2 in shards.sbatch"
t0=$(date +%s)
bash -c "$submit" >"$tmp/submitted" || fail "sbatch failed: $(cat "$tmp/submitted")"
echo "sbatch: $(cat "$tmp/submitted") (the merge, after the array)"
for _ in $(seq 600); do
  [ -z "$(squeue -h -o %i 2>/dev/null)" ] && break
  sleep 1
done
[ -z "$(squeue -h -o %i)" ] || fail "jobs still queued after 600 s: $(squeue -h)"
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
