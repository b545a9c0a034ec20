#!/usr/bin/env bash
# A one-node Slurm cluster on localhost, for tests and benchmarks (docs/cluster.md): munged,
# slurmctld and slurmd from Debian's slurm-wlm and munge, every file in one folder, loopback
# only, on free ports. Source it, then:
#
#   local_slurm_start DIR   starts the cluster; exports SLURM_CONF; returns 77 with a line on
#                           stderr saying why when Slurm is not installed or cannot start
#   local_slurm_stop DIR    cancels every job and stops the daemons
#
# The node gets this machine's CPU count; jobs run as the calling user.

local_slurm_start() {
  local dir=$1 tool
  for tool in munged mungekey slurmctld slurmd sbatch squeue scancel sinfo; do
    if ! command -v "$tool" >/dev/null 2>&1; then
      echo "Slurm is not installed: '$tool' not found (apt-get install slurm-wlm munge)" >&2
      return 77
    fi
  done
  mkdir -p "$dir/state" "$dir/spool" "$dir/log"
  export SLURM_CONF=$dir/slurm.conf
  unset SLURM_JOB_ID SLURM_ARRAY_TASK_ID SLURM_ARRAY_JOB_ID  # When called inside a Slurm job.
  local free_port='import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'
  local ctl_port d_port user cpus state=""
  ctl_port=$(/usr/bin/python3 -c "$free_port")
  d_port=$(/usr/bin/python3 -c "$free_port")
  while [ "$d_port" = "$ctl_port" ]; do d_port=$(/usr/bin/python3 -c "$free_port"); done
  user=$(id -un)
  cpus=$(nproc)
  if ! mungekey --create --keyfile="$dir/munge.key" --force >/dev/null 2>&1; then
    echo "mungekey could not create a key in $dir" >&2
    return 77
  fi
  chmod 600 "$dir/munge.key"
  if ! munged --force --socket="$dir/munge.sock" --key-file="$dir/munge.key" \
    --log-file="$dir/log/munged.log" --pid-file="$dir/munged.pid" --seed-file="$dir/munged.seed"; then
    echo "munged could not start: $(tail -n 1 "$dir/log/munged.log" 2>/dev/null)" >&2
    return 77
  fi
  cat >"$SLURM_CONF" <<EOF
ClusterName=shadefit-local
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=$user
SlurmdUser=$user
SlurmctldPort=$ctl_port
SlurmdPort=$d_port
AuthType=auth/munge
AuthInfo=socket=$dir/munge.sock
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
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
  if ! slurmctld -f "$SLURM_CONF" -i >/dev/null 2>&1; then
    echo "slurmctld could not start: $(tail -n 1 "$dir/log/slurmctld.log" 2>/dev/null)" >&2
    return 77
  fi
  if ! slurmd -f "$SLURM_CONF" -N localhost >/dev/null 2>&1; then
    echo "slurmd could not start: $(tail -n 1 "$dir/log/slurmd.log" 2>/dev/null)" >&2
    return 77
  fi
  local _
  for _ in $(seq 60); do
    state=$(sinfo -h -N -o %t 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 0.5
  done
  if [ "$state" != idle ]; then
    echo "the local Slurm node did not come up (state '$state'): $(tail -n 1 "$dir/log/slurmd.log")" >&2
    return 77
  fi
  echo "slurm: one-node cluster up on 127.0.0.1:$ctl_port ($cpus CPUs, partition 'local')"
}

# Waits until the queue is empty (at most $2 seconds, default 600); 1 if it is not.
local_slurm_wait() {
  local limit=${1:-600} _
  for _ in $(seq "$limit"); do
    [ -z "$(squeue -h -o %i 2>/dev/null)" ] && return 0
    sleep 1
  done
  [ -z "$(squeue -h -o %i 2>/dev/null)" ]
}

local_slurm_stop() {
  local dir=$1 pidfile
  [ -f "$dir/slurm.conf" ] && SLURM_CONF=$dir/slurm.conf scancel --quiet --user="$(id -un)" 2>/dev/null
  for pidfile in "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munged.pid"; do
    [ -s "$pidfile" ] && kill "$(cat "$pidfile")" 2>/dev/null
  done
  sleep 1
  for pidfile in "$dir/slurmd.pid" "$dir/slurmctld.pid" "$dir/munged.pid"; do
    [ -s "$pidfile" ] && kill -9 "$(cat "$pidfile")" 2>/dev/null
  done
  return 0
}
