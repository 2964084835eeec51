#!/usr/bin/env bash
# A one-node Slurm on this machine, for the cluster tests (and for trying the cluster
# scripts before a real cluster):
#
#   scripts/slurm-local.sh start    # installs slurm-wlm and munge when missing (as root, with
#                                   # apt-get), writes target/slurm/slurm.conf for this
#                                   # machine, starts munged, slurmctld and slurmd on localhost
#   scripts/slurm-local.sh stop     # stops them, by their process ids
#   scripts/slurm-local.sh env      # the SLURM_CONF line to export for sbatch and friends
#
# Everything it writes (config, state, logs, pid files) is under target/slurm.
set -euo pipefail
cd "$(dirname "$0")/.."
dir="$(pwd)/target/slurm"
conf="$dir/slurm.conf"
munge_dir="$dir/munge"

install() {
  if command -v sbatch >/dev/null && command -v slurmctld >/dev/null && command -v slurmd >/dev/null &&
    command -v munged >/dev/null; then
    return
  fi
  if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null; then
    echo "slurm-local: Slurm is not installed and cannot be (needs root and apt-get)" >&2
    exit 3
  fi
  echo "slurm-local: installing slurm-wlm and munge"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge >/dev/null
}

write_conf() {
  mkdir -p "$dir/state" "$dir/spool" "$munge_dir"
  local cpus mem_mb
  cpus=$(nproc)
  mem_mb=$(awk '/MemTotal/ { print int($2 / 1024 * 0.8) }' /proc/meminfo)
  cat >"$conf" <<EOF
ClusterName=smartteams-local
SlurmctldHost=localhost(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$munge_dir/munge.socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
ReturnToService=2
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
KillWait=30
MinJobAge=30
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
}

start() {
  install
  stop_daemons quietly
  write_conf
  munged --force --socket="$munge_dir/munge.socket" --pid-file="$munge_dir/munged.pid" \
    --log-file="$munge_dir/munged.log" --seed-file="$munge_dir/munged.seed"
  slurmctld -f "$conf"
  slurmd -f "$conf" -N localhost
  export SLURM_CONF="$conf"
  for _ in $(seq 1 60); do
    if sinfo -h -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then
      echo "slurm-local: up (SLURM_CONF=$conf)"
      return
    fi
    sleep 0.5
  done
  echo "slurm-local: the node did not come up; see $dir/*.log" >&2
  exit 1
}

stop_daemons() {
  for pidfile in "$dir/slurmd.pid" "$dir/slurmctld.pid" "$munge_dir/munged.pid"; do
    if [ -s "$pidfile" ]; then
      kill "$(cat "$pidfile")" 2>/dev/null || true
      rm -f "$pidfile"
    fi
  done
  [ "${1:-}" = quietly ] || echo "slurm-local: stopped"
}

case "${1:-}" in
  start) start ;;
  stop) stop_daemons ;;
  env) echo "export SLURM_CONF=$conf" ;;
  *)
    echo "usage: $0 start|stop|env" >&2
    exit 2
    ;;
esac
