#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for sharded bakes and their test (docs/pipelines.md).
# Usage: scripts/slurm-local.sh start|stop|status|env
#   start   installs what is missing (slurmctld, slurmd, slurm-client, munge), starts munged if no munge
#           daemon answers, writes the cluster's slurm.conf, starts slurmctld and slurmd, and waits until
#           the node is idle. A second start while it runs does nothing.
#   stop    cancels the cluster's jobs, stops slurmctld and slurmd, and munged if this script started it.
#   status  prints the daemons and the node; exit 0 when the node is up, 1 when not.
#   env     prints `export SLURM_CONF=...`: run `eval "$(scripts/slurm-local.sh env)"` before sbatch/sinfo.
# Everything lives in $CPVS_SLURM_DIR (default /var/lib/cpvs-slurm): slurm.conf, state, spool, logs, pid
# files. Nothing is written to /etc/slurm, so an administrator's Slurm configuration is left alone. The
# daemons listen on ports 16817 (slurmctld) and 16818 (slurmd), not Slurm's 6817/6818.
# Needs root. Works without systemd and without cgroups (daemons are started directly).
set -euo pipefail

dir="${CPVS_SLURM_DIR:-/var/lib/cpvs-slurm}"
conf="$dir/slurm.conf"
log_dir="$dir/log"
ctld_pidfile="$dir/slurmctld.pid"
slurmd_pidfile="$dir/slurmd.pid"
munged_ours="$dir/munged.pid" # present only when this script started munged
node="$(hostname -s 2>/dev/null || hostname)"
export SLURM_CONF="$conf"

say() { echo "slurm-local: $*"; }
die() { echo "slurm-local: error: $*" >&2; exit 1; }

# alive PID NAME: the process PID is still NAME.
alive() {
  local comm
  comm="$(cat "/proc/$1/comm" 2>/dev/null)" || return 1
  case "$comm" in "$2"*) return 0 ;; *) return 1 ;; esac
}

# pid_of FILE NAME: prints the pid in FILE when that process is alive and is NAME (guards against reuse).
pid_of() {
  local pid
  [ -r "$1" ] || return 1
  pid="$(tr -dc '0-9' <"$1")"
  [ -n "$pid" ] && alive "$pid" "$2" && echo "$pid"
}

node_state() { sinfo -h -N -n "$node" -o %T 2>/dev/null | head -n1; }

# The node is usable when slurmctld answers and the node takes jobs.
node_up() {
  case "$(node_state)" in
    idle | mixed | allocated | completing) return 0 ;;
    *) return 1 ;;
  esac
}

show_logs() {
  local f
  for f in "$log_dir/slurmctld.log" "$log_dir/slurmd.log"; do
    [ -r "$f" ] || continue
    echo "---- last lines of $f" >&2
    tail -n 15 "$f" >&2
  done
}

install_missing() {
  local needed=(slurmctld slurmd slurm-client munge) missing=() p
  for p in "${needed[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  command -v apt-get >/dev/null || die "missing packages ${missing[*]} and no apt-get to install them"
  say "installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q >/dev/null || die "apt-get update failed"
  apt-get install -y -q --no-install-recommends "${missing[@]}" >/dev/null || die "apt-get install ${missing[*]} failed"
}

munge_works() { munge -n 2>/dev/null | unmunge >/dev/null 2>&1; }

start_munge() {
  if munge_works; then return 0; fi
  local key=/etc/munge/munge.key i
  id munge >/dev/null 2>&1 || die "no 'munge' user (is the munge package installed?)"
  install -d -o munge -g munge -m 0700 /etc/munge
  install -d -o munge -g munge -m 0755 /run/munge
  install -d -o munge -g munge -m 0711 /var/lib/munge
  install -d -o munge -g munge -m 0700 /var/log/munge
  if [ ! -e "$key" ]; then
    say "creating the munge key $key"
    runuser -u munge -- mungekey --create --keyfile="$key" || die "cannot create $key"
  fi
  chown munge:munge "$key"
  chmod 0400 "$key"
  say "starting munged"
  runuser -u munge -- munged || die "munged did not start (see /var/log/munge/munged.log)"
  for i in $(seq 50); do
    if munge_works; then
      cp /run/munge/munged.pid "$munged_ours" 2>/dev/null || true
      return 0
    fi
    sleep 0.2
  done
  die "munged started but does not answer (see /var/log/munge/munged.log)"
}

write_conf() {
  local cpus mem
  cpus="$(nproc)"
  # RealMemory in MiB, as slurmd measures it (a larger value would drain the node).
  mem="$(awk '/^MemTotal:/ {print int($2 / 1024)}' /proc/meminfo)"
  mkdir -p "$dir/state" "$dir/spool" "$log_dir"
  cat >"$conf.tmp" <<EOF
# Written by scripts/slurm-local.sh: a one-node cluster on this machine. Rewritten at every start.
ClusterName=cpvs-local
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$ctld_pidfile
SlurmdPidFile=$slurmd_pidfile
SlurmctldLogFile=$log_dir/slurmctld.log
SlurmdLogFile=$log_dir/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# No cgroups and no systemd: track job processes through /proc, bind nothing.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SwitchType=switch/none
# CPUs are the consumable resource, so several one-CPU jobs (array tasks) run at once.
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
# Start a batch job as soon as it can run (Slurm waits up to 3 s by default, which dominates short bakes).
SchedulerParameters=batch_sched_delay=0
MailProg=/bin/true
ReturnToService=2
MinJobAge=300
NodeName=$node NodeAddr=127.0.0.1 NodeHostname=$node CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=local Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
  mv "$conf.tmp" "$conf"
}

stop_daemons() {
  local pid i name ctld_pid="" slurmd_pid="" jobs
  ctld_pid="$(pid_of "$ctld_pidfile" slurmctld)" || true
  slurmd_pid="$(pid_of "$slurmd_pidfile" slurmd)" || true
  if [ -n "$ctld_pid" ]; then
    jobs="$(squeue -h -o %A 2>/dev/null | sort -u | tr '\n' ' ')"
    if [ -n "${jobs// /}" ]; then
      say "cancelling jobs $jobs"
      # shellcheck disable=SC2086
      scancel $jobs 2>/dev/null || true
      for i in $(seq 20); do
        [ -z "$(squeue -h -o %A 2>/dev/null)" ] && break
        sleep 0.5
      done
    fi
    scontrol shutdown >/dev/null 2>&1 || true
  fi
  # The daemons remove their pid files before they are gone: wait on the pids read above.
  for name in slurmd slurmctld; do
    if [ $name = slurmd ]; then pid="$slurmd_pid"; else pid="$ctld_pid"; fi
    if [ -n "$pid" ]; then
      for i in $(seq 60); do
        alive "$pid" "$name" || break
        [ "$i" -eq 20 ] && kill -TERM "$pid" 2>/dev/null
        sleep 0.25
      done
      if alive "$pid" "$name"; then
        say "$name ($pid) ignored SIGTERM; killing it"
        kill -KILL "$pid" 2>/dev/null || true
        sleep 0.5
      fi
    fi
    rm -f "$dir/$name.pid"
  done
}

cmd_start() {
  [ "$(id -u)" -eq 0 ] || die "start needs root (it installs packages and runs the Slurm daemons)"
  local t0=$SECONDS
  mkdir -p "$dir"
  install_missing
  for b in slurmctld slurmd sinfo sbatch scontrol munged munge; do
    command -v "$b" >/dev/null || die "$b not found after installing"
  done

  if pid_of "$ctld_pidfile" slurmctld >/dev/null && pid_of "$slurmd_pidfile" slurmd >/dev/null && node_up; then
    say "already running: node $node $(node_state); SLURM_CONF=$conf"
    return 0
  fi
  # Half up (one daemon died, or the node is down): restart both from a clean state.
  stop_daemons

  start_munge
  write_conf
  say "starting slurmctld and slurmd (SLURM_CONF=$conf, logs in $log_dir)"
  : >"$log_dir/slurmctld.log"
  : >"$log_dir/slurmd.log"
  # -c: forget jobs of an earlier run of this test cluster; -i: ignore unreadable state files.
  slurmctld -c -i -f "$conf" || { show_logs; die "slurmctld did not start"; }
  slurmd -f "$conf" -N "$node" || { show_logs; die "slurmd did not start"; }

  local state="" resumed=0 i
  for i in $(seq 120); do # 60 s
    state="$(node_state)"
    case "$state" in
      idle | mixed | allocated | completing) break ;;
      down* | drain*)
        if [ $resumed -eq 0 ] && pid_of "$slurmd_pidfile" slurmd >/dev/null; then
          if scontrol update nodename="$node" state=resume >/dev/null 2>&1; then resumed=1; fi
        fi
        ;;
    esac
    if ! pid_of "$ctld_pidfile" slurmctld >/dev/null || ! pid_of "$slurmd_pidfile" slurmd >/dev/null; then
      sleep 0.5 # a daemon that just forked may not have written its pid file yet
      if ! pid_of "$ctld_pidfile" slurmctld >/dev/null || ! pid_of "$slurmd_pidfile" slurmd >/dev/null; then
        show_logs
        stop_daemons
        die "a Slurm daemon exited during start (logs above, full logs in $log_dir)"
      fi
    fi
    sleep 0.5
  done
  if ! node_up; then
    scontrol show node "$node" 2>/dev/null | grep -E 'State=|Reason=' >&2 || true
    show_logs
    stop_daemons
    die "node $node not idle after 60 s (state: ${state:-no answer from slurmctld})"
  fi
  say "running: node $node $state, $(nproc) CPUs, partition 'local' ($((SECONDS - t0)) s)"
  say "before sbatch/squeue/sinfo: export SLURM_CONF=$conf"
}

cmd_stop() {
  [ "$(id -u)" -eq 0 ] || die "stop needs root"
  local stopped=0 pid
  if pid_of "$ctld_pidfile" slurmctld >/dev/null || pid_of "$slurmd_pidfile" slurmd >/dev/null; then
    stop_daemons
    stopped=1
  fi
  if pid="$(pid_of "$munged_ours" munged)"; then
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 20); do
      [ -d "/proc/$pid" ] || break
      sleep 0.25
    done
    stopped=1
  fi
  rm -f "$munged_ours"
  if [ $stopped -eq 1 ]; then say "stopped"; else say "not running"; fi
}

cmd_status() {
  local pid ok=0
  echo "SLURM_CONF=$conf"
  if pid="$(pid_of "$ctld_pidfile" slurmctld)"; then echo "slurmctld: running ($pid)"; else echo "slurmctld: stopped"; ok=1; fi
  if pid="$(pid_of "$slurmd_pidfile" slurmd)"; then echo "slurmd:    running ($pid)"; else echo "slurmd:    stopped"; ok=1; fi
  if munge_works; then echo "munge:     answering"; else echo "munge:     not answering"; ok=1; fi
  if [ $ok -eq 0 ]; then
    sinfo -N -o "%N %T %c %m %P" 2>/dev/null || true
    squeue 2>/dev/null || true
    node_up || ok=1
  fi
  return $ok
}

case "${1:-}" in
  start) cmd_start ;;
  stop) cmd_stop ;;
  status) cmd_status ;;
  env) echo "export SLURM_CONF=$conf" ;;
  -h | --help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0" ;;
  *)
    echo "usage: $0 start|stop|status|env" >&2
    exit 2
    ;;
esac
