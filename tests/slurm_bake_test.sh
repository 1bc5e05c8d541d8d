#!/usr/bin/env bash
# A sharded bake on Slurm gives the same bytes as one cpvs-bake run.
# Usage: bash tests/slurm_bake_test.sh BUILD_BIN_DIR [SCENE]
# Starts the local one-node cluster (scripts/slurm-local.sh; installs Slurm if missing, so it needs root),
# bakes SCENE (default: a generated city with 12 spot lights) at -r 256 in 4 shards through
# scripts/slurm-bake.sh --wait, bakes it again in one process, and compares the two files. Stops the cluster
# again if it was not running before. The shards ask for 2G each, which must reach their bakes as
# CPVS_MEMORY_LIMIT. Exit 0 PASS, 1 FAIL.
set -uo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"

fail() {
  echo "slurm_bake_test: FAIL: $*"
  exit 1
}
[ $# -ge 1 ] && [ $# -le 2 ] || fail "usage: $0 BUILD_BIN_DIR [SCENE]"
# Starting (and installing) the cluster needs root, as CI has; elsewhere the test is skipped (CTest: 77).
if [ "$(id -u)" -ne 0 ] && ! bash "$root/scripts/slurm-local.sh" status >/dev/null 2>&1; then
  echo "slurm_bake_test: SKIP: not root and no local Slurm running (scripts/slurm-local.sh start needs root)"
  exit 77
fi
bin="$(realpath -m "$1")"
[ -x "$bin/cpvs-bake" ] || fail "$bin/cpvs-bake not found"
[ -x "$bin/cpvs-merge" ] || fail "$bin/cpvs-merge not found"

tmp="$(mktemp -d)"
if [ $# -eq 2 ]; then
  scene="$(realpath -m "$2")"
else
  scene="$tmp/spots.glb"
  "$bin/cpvs-scenegen" city-spots --triangles 5000 --lights 12 -o "$scene" >/dev/null || fail "cpvs-scenegen failed"
fi
[ -r "$scene" ] || fail "scene $scene not found"
started=0
cleanup() {
  [ $started -eq 1 ] && bash "$root/scripts/slurm-local.sh" stop >/dev/null 2>&1
  rm -rf "$tmp"
}
trap cleanup EXIT

bash "$root/scripts/slurm-local.sh" status >/dev/null 2>&1 || started=1
bash "$root/scripts/slurm-local.sh" start || fail "the local Slurm cluster did not start"
eval "$(bash "$root/scripts/slurm-local.sh" env)"

t0=$SECONDS
# With a memory request, which must reach each shard's bake as its memory limit.
SBATCH_MEM_PER_NODE=2G bash "$root/scripts/slurm-bake.sh" -n 4 -o "$tmp/merged.cpvs" --bin "$bin" --workdir "$tmp/parts" \
  --wait --timeout 240 "$scene" -r 256 || fail "the sharded bake on Slurm failed"
t1=$SECONDS
"$bin/cpvs-bake" "$scene" -r 256 -o "$tmp/single.cpvs" -q || fail "the single cpvs-bake run failed"

grep -q "memory limit: CPVS_MEMORY_LIMIT=2048M" "$tmp/parts/shard_0.log" ||
  fail "the job's memory request (2G) did not reach the shard as CPVS_MEMORY_LIMIT: $(cat "$tmp/parts/shard_0.log")"
cmp "$tmp/merged.cpvs" "$tmp/single.cpvs" ||
  fail "the merged file ($(stat -c %s "$tmp/merged.cpvs") bytes) differs from the single run's ($(stat -c %s "$tmp/single.cpvs") bytes)"
echo "slurm_bake_test: PASS: 4 shards on Slurm merged ($((t1 - t0)) s) equal one cpvs-bake run byte for byte ($(stat -c %s "$tmp/single.cpvs") bytes)"
