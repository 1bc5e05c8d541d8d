#!/usr/bin/env bash
# Bakes a scene in N shards on Slurm, then merges them (docs/pipelines.md).
# Usage: scripts/slurm-bake.sh -n SHARDS -o OUT.cpvs [options] SCENE [cpvs-bake flags...]
#   -n, --shards N        number of shards: one array task each (cpvs-bake --shard I/N)
#   -o, --output FILE     the merged .cpvs, byte for byte what one cpvs-bake run writes
#   --bin DIR             folder holding cpvs-bake and cpvs-merge, seen at the same path by every node
#                         (default: this checkout's build/bin)
#   --workdir DIR         parts, job scripts and logs (default: OUT without .cpvs, plus .parts); on a
#                         cluster it must be on a filesystem every node shares
#   -c, --cpus-per-task C CPUs per shard, passed to cpvs-bake as -j C unless the flags give -j (default 1)
#   --wait                block until the merge job ends; exit non-zero and show the failing logs if a job failed
#   --timeout SECONDS     with --wait: give up after this long and cancel the jobs (default: no limit)
# Everything after SCENE goes to every shard's cpvs-bake (e.g. -r 4k --sun 0,-1,0.3). Paths are made
# absolute; jobs run in WORKDIR, so a relative path inside the bake flags is taken from there.
# sbatch reads its usual environment: SBATCH_PARTITION, SBATCH_ACCOUNT, SBATCH_TIMELIMIT, SBATCH_QOS...
# A memory request (SBATCH_MEM_PER_NODE, SBATCH_MEM_PER_CPU) reaches each shard's cpvs-bake as CPVS_MEMORY_LIMIT,
# its memory limit (the default budget is an eighth below it).
# Slurm configuration: SLURM_CONF if set; else the system's (/etc/slurm/slurm.conf); else the local test
# cluster of scripts/slurm-local.sh.
# Exit codes: 0 submitted (or, with --wait, merged); 1 usage error or missing input; 4 sbatch failed, a job
# failed, or --timeout passed.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"

usage() { awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; }
die() { echo "slurm-bake: error: $*" >&2; exit 1; }
fail() { echo "slurm-bake: FAILED: $*" >&2; exit 4; }
say() { echo "slurm-bake: $*"; }

shards="" out="" bin="$root/build/bin" workdir="" wait=0 timeout=0 cpus=1
while [ $# -gt 0 ]; do
  case "$1" in
    -n | --shards) shards="${2:?-n needs a value}"; shift 2 ;;
    --shards=*) shards="${1#*=}"; shift ;;
    -o | --output) out="${2:?-o needs a value}"; shift 2 ;;
    --output=*) out="${1#*=}"; shift ;;
    --bin) bin="${2:?--bin needs a value}"; shift 2 ;;
    --bin=*) bin="${1#*=}"; shift ;;
    --workdir) workdir="${2:?--workdir needs a value}"; shift 2 ;;
    --workdir=*) workdir="${1#*=}"; shift ;;
    -c | --cpus-per-task) cpus="${2:?-c needs a value}"; shift 2 ;;
    --cpus-per-task=*) cpus="${1#*=}"; shift ;;
    --wait) wait=1; shift ;;
    --timeout) timeout="${2:?--timeout needs a value}"; shift 2 ;;
    --timeout=*) timeout="${1#*=}"; shift ;;
    -h | --help) usage; exit 0 ;;
    --) shift; break ;;
    -*) echo "slurm-bake: error: unknown option $1 (options go before SCENE)" >&2; usage >&2; exit 1 ;;
    *) break ;;
  esac
done
[ $# -ge 1 ] || { echo "slurm-bake: error: no SCENE given" >&2; usage >&2; exit 1; }
scene="$1"
shift
flags=("$@")

[[ "$shards" =~ ^[0-9]+$ ]] || die "-n SHARDS must be a whole number >= 1 (got '${shards}')"
[[ "$cpus" =~ ^[0-9]+$ ]] || die "--cpus-per-task must be a whole number >= 1 (got '${cpus}')"
[[ "$timeout" =~ ^[0-9]+$ ]] || die "--timeout must be a whole number of seconds (got '${timeout}')"
shards=$((10#$shards)) cpus=$((10#$cpus)) timeout=$((10#$timeout)) # 08 is eight, not bad octal
[ "$shards" -ge 1 ] || die "-n SHARDS must be at least 1"
[ "$cpus" -ge 1 ] || die "--cpus-per-task must be at least 1"
[ -n "$out" ] || die "-o OUT.cpvs is required"
[ -r "$scene" ] || die "scene $scene not found or not readable"
scene="$(realpath "$scene")"
out="$(realpath -m "$out")"
bin="$(realpath -m "$bin")"
[ -n "$workdir" ] || workdir="${out%.cpvs}.parts"
workdir="$(realpath -m "$workdir")"
for tool in cpvs-bake cpvs-merge; do
  [ -x "$bin/$tool" ] || die "$bin/$tool not found or not executable (give --bin DIR)"
done
[ -d "$(dirname "$out")" ] || die "output folder $(dirname "$out") does not exist"

add_threads=1 add_quiet=1
for f in "${flags[@]}"; do
  case "$f" in
    -o | --output | --output=* | -o?*) die "do not pass -o in the bake flags: each shard writes WORKDIR/part_I.cpvs" ;;
    --shard | --shard=*) die "do not pass --shard: the script gives each array task its own" ;;
    -j | -j?* | --threads | --threads=*) add_threads=0 ;;
    -q | --quiet) add_quiet=0 ;;
  esac
done
[ $add_threads -eq 1 ] && flags+=(-j "$cpus")
[ $add_quiet -eq 1 ] && flags+=(-q)

# Slurm configuration: the caller's, else the system's, else the local test cluster's.
if [ -z "${SLURM_CONF:-}" ] && [ ! -e /etc/slurm/slurm.conf ]; then
  local_conf="${CPVS_SLURM_DIR:-/var/lib/cpvs-slurm}/slurm.conf"
  [ -e "$local_conf" ] && export SLURM_CONF="$local_conf"
fi
command -v sbatch >/dev/null || die "sbatch not found: install slurm-client, or run scripts/slurm-local.sh start"

mkdir -p "$workdir"
q() { [ $# -eq 0 ] || printf '%q ' "$@"; }

# One array task per shard. The scripts are kept in WORKDIR as a record of what ran.
cat >"$workdir/shard.sh" <<EOF
#!/usr/bin/env bash
# Written by scripts/slurm-bake.sh: shard \$SLURM_ARRAY_TASK_ID of $shards.
set -eu
i="\${SLURM_ARRAY_TASK_ID:?not started as a Slurm array task}"
echo "shard \$i/$shards on \$(hostname), job \${SLURM_JOB_ID:-?}"
# The job's memory request is the bake's memory limit: cpvs-bake budgets an eighth below it and stops with
# exit 4 and a message before Slurm would kill the shard (0 asks for the whole node: the node's limits apply).
if [ "\${SLURM_MEM_PER_NODE:-0}" -gt 0 ]; then
  export CPVS_MEMORY_LIMIT="\${SLURM_MEM_PER_NODE}M"
elif [ "\${SLURM_MEM_PER_CPU:-0}" -gt 0 ]; then
  export CPVS_MEMORY_LIMIT="\$((SLURM_MEM_PER_CPU * \${SLURM_CPUS_ON_NODE:-1}))M"
fi
[ -z "\${CPVS_MEMORY_LIMIT:-}" ] || echo "memory limit: CPVS_MEMORY_LIMIT=\$CPVS_MEMORY_LIMIT"
exec $(q "$bin/cpvs-bake" "$scene") --shard "\$i/$shards" -o $(printf '%q' "$workdir")/part_"\$i".cpvs $(q "${flags[@]}")
EOF
parts=()
for ((i = 0; i < shards; i++)); do parts+=("$workdir/part_$i.cpvs"); done
cat >"$workdir/merge.sh" <<EOF
#!/usr/bin/env bash
# Written by scripts/slurm-bake.sh: joins the $shards parts into the output.
set -eu
exec $(q "$bin/cpvs-merge" "${parts[@]}") -o $(printf '%q' "$out")
EOF
chmod +x "$workdir/shard.sh" "$workdir/merge.sh"
: >"$workdir/.submitted" # its time tells a fresh output from an old one if the merge job is forgotten

common=(--parsable --ntasks=1 --chdir="$workdir")
shard_job="$(sbatch "${common[@]}" --job-name=cpvs-bake --array="0-$((shards - 1))" --cpus-per-task="$cpus" \
  --output="$workdir/shard_%a.log" "$workdir/shard.sh")" || fail "sbatch of the shards failed"
shard_job="${shard_job%%;*}"
merge_job="$(sbatch "${common[@]}" --job-name=cpvs-merge --dependency="afterok:$shard_job" --kill-on-invalid-dep=yes \
  --output="$workdir/merge.log" "$workdir/merge.sh")" || {
  scancel "$shard_job" 2>/dev/null || true
  fail "sbatch of the merge failed (shards cancelled)"
}
merge_job="${merge_job%%;*}"
say "shards: job $shard_job (array 0-$((shards - 1))), logs $workdir/shard_I.log"
say "merge:  job $merge_job (after every shard succeeds), log $workdir/merge.log"
say "output: $out"
if [ $wait -eq 0 ]; then
  say "watch with: squeue -j $shard_job,$merge_job"
  exit 0
fi

# job_state ID: the state of one job, empty once Slurm has forgotten it.
job_state() { scontrol show job -o "$1" 2>/dev/null | head -n1 | sed -nE 's/.* JobState=([A-Z_]+).*/\1/p'; }

report_shards() {
  local line task state code shown=0
  while read -r line; do
    task="$(sed -nE 's/.* ArrayTaskId=([0-9]+) .*/\1/p' <<<"$line")"
    state="$(sed -nE 's/.* JobState=([A-Z_]+) .*/\1/p' <<<"$line")"
    code="$(sed -nE 's/.* ExitCode=([0-9:]+) .*/\1/p' <<<"$line")"
    [ -n "$task" ] || continue
    case "$state" in COMPLETED | PENDING | RUNNING) continue ;; esac
    echo "slurm-bake: shard $task: $state (exit code $code); last lines of $workdir/shard_$task.log:" >&2
    tail -n 20 "$workdir/shard_$task.log" 2>/dev/null | sed 's/^/  | /' >&2 || true
    shown=1
  done < <(scontrol show job -o "$shard_job" 2>/dev/null)
  if [ $shown -eq 0 ]; then
    for ((i = 0; i < shards; i++)); do
      [ -e "$workdir/part_$i.cpvs" ] && continue
      echo "slurm-bake: shard $i wrote no part; last lines of $workdir/shard_$i.log:" >&2
      tail -n 20 "$workdir/shard_$i.log" 2>/dev/null | sed 's/^/  | /' >&2 || true
    done
  fi
}

start=$SECONDS delay=1 state=""
while :; do
  state="$(job_state "$merge_job")"
  case "$state" in
    PENDING | RUNNING | CONFIGURING | COMPLETING | SUSPENDED | REQUEUED | REQUEUE_HOLD | REQUEUE_FED | RESIZING | SIGNALING | STAGE_OUT) ;;
    *) break ;;
  esac
  if [ "$timeout" -gt 0 ] && [ $((SECONDS - start)) -ge "$timeout" ]; then
    scancel "$shard_job" "$merge_job" 2>/dev/null || true
    fail "still $state after ${timeout} s; cancelled jobs $shard_job and $merge_job"
  fi
  sleep "$delay"
  [ $((SECONDS - start)) -ge 30 ] && delay=5
done

case "$state" in
  COMPLETED)
    [ -e "$out" ] || fail "merge job $merge_job completed but $out is missing"
    say "done in $((SECONDS - start)) s: $out"
    ;;
  "")
    # Slurm forgot the job (MinJobAge passed, or slurmctld restarted): judge by the output.
    if [ -e "$out" ] && [ "$out" -nt "$workdir/.submitted" ]; then
      say "done: $out (job $merge_job no longer known to Slurm)"
    else
      report_shards
      fail "job $merge_job is no longer known to Slurm and $out was not written"
    fi
    ;;
  *)
    reason="$(scontrol show job -o "$merge_job" 2>/dev/null | sed -nE 's/.* Reason=([^ ]+) .*/\1/p')"
    if [ "$state" = CANCELLED ] && [ "$reason" = DependencyNeverSatisfied ]; then
      report_shards
      scancel "$shard_job" 2>/dev/null || true
      fail "a shard failed, so the merge job $merge_job was cancelled (remaining shards cancelled too)"
    fi
    report_shards
    echo "slurm-bake: merge job $merge_job: $state${reason:+ ($reason)}; last lines of $workdir/merge.log:" >&2
    tail -n 20 "$workdir/merge.log" 2>/dev/null | sed 's/^/  | /' >&2 || true
    fail "merge job $merge_job ended $state"
    ;;
esac
