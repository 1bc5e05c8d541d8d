#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/, clang) and runs each for SECONDS (default 60) from a seed corpus made of
# the repo's own files: the golden .cpvs files and small bakes, the bundled self-contained glTF scenes (and a
# GLB made from one), the compressed GLBs of tests/data/compressed, and point files in CSV, PLY and EXR.
# Corpora grow in out/fuzz/corpus/TARGET, crashes land in out/fuzz/artifacts/TARGET; a summary line per target
# (executions, corpus, crashes) is printed and written to out/fuzz/summary.txt. Exit 1 when any target crashed.
#   scripts/fuzz.sh [SECONDS] [TARGET ...]     targets: fuzz_cpvs fuzz_cpvs_semantic fuzz_gltf fuzz_points
# CPVS_FUZZ_BUILD and CPVS_FUZZ_OUT move the build folder and out/fuzz (the test suite's short run uses its own).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(fuzz_cpvs fuzz_cpvs_semantic fuzz_gltf fuzz_points)
build="${CPVS_FUZZ_BUILD:-$root/build-fuzz}"
out="${CPVS_FUZZ_OUT:-$root/out/fuzz}"
CC=clang CXX=clang++ cmake -S "$root/fuzz" -B "$build" -G Ninja >/dev/null
ninja -C "$build" "${targets[@]}" >/dev/null

seed() {  # seed TARGET: fills out/fuzz/corpus/TARGET once
  local dir="$out/corpus/$1"
  [ -d "$dir" ] && return 0
  mkdir -p "$dir"
  case "$1" in
    fuzz_cpvs|fuzz_cpvs_semantic)
      cp "$root"/formats/cpvs/golden/*.cpvs "$root"/tests/golden/*.cpvs "$dir/"
      if [ -x "$root/build/bin/cpvs-bake" ]; then  # small bakes with spot and point lights too
        "$root/build/bin/cpvs-bake" "$root/data/scenes/TorusKnot/torusknot.gltf" -r 32 --sun 0.3,-1,0.2 \
          --spot 10,60,-30,-0.15,-0.85,0.5,0.6,200 --point 0,30,0,0 -o "$dir/tk32.cpvs" --quiet || true
      fi ;;
    fuzz_gltf)
      for f in Tiny/tiny.gltf TorusKnot/torusknot.gltf; do cp "$root/data/scenes/$f" "$dir/"; done
      cp "$root"/tests/fuzz-regressions/gltf-*.gltf "$dir/"  # inputs that once failed: replayed every run
      # Compressed geometry and GPU instancing (meshopt, Draco, EXT_mesh_gpu_instancing), self-contained GLBs.
      for f in tiny_meshopt_khr tiny_draco tiny_instanced torusknot_meshopt torusknot_draco; do
        cp "$root/tests/data/compressed/$f.glb" "$dir/"
      done
      python3 - "$root/data/scenes/Tiny/tiny.gltf" "$dir/tiny.glb" <<'PY'
import base64, json, struct, sys
g = json.load(open(sys.argv[1]))
blob = b""
for b in g.get("buffers", []):
    uri = b.pop("uri", "")
    if uri.startswith("data:"):
        blob += base64.b64decode(uri.split(",", 1)[1])
g["buffers"] = [{"byteLength": len(blob)}] if blob else []
js = json.dumps(g, separators=(",", ":")).encode()
js += b" " * (-len(js) % 4)
blob += b"\0" * (-len(blob) % 4)
chunks = struct.pack("<II", len(js), 0x4E4F534A) + js + (struct.pack("<II", len(blob), 0x004E4942) + blob if blob else b"")
open(sys.argv[2], "wb").write(struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks)
PY
      ;;
    fuzz_points)
      printf '\000x,y,z,nx,ny,nz\n1,2,3,0,1,0\n-1e3,0.5,7,0,0,1\n' > "$dir/points.csv"
      printf '\001ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 5 6\n' > "$dir/points.ply"
      if [ -x "$root/build/bin/cpvs-bake" ]; then  # an EXR as the tools write it (depth dumps)
        "$root/build/bin/cpvs-bake" "$root/data/scenes/TorusKnot/torusknot.gltf" -r 16 --sun 0.3,-1,0.2 \
          --dump-depth "$out/exr-seed" --quiet || true
        for e in "$out"/exr-seed/*.exr; do [ -f "$e" ] && { printf '\002' | cat - "$e" > "$dir/$(basename "$e")"; }; done
      fi ;;
  esac
}

status=0
mkdir -p "$out"
: > "$out/summary.txt"
for t in "${targets[@]}"; do
  seed "$t"
  mkdir -p "$out/artifacts/$t"
  log="$out/$t.log"
  start=$(date +%s)
  set +e
  "$build/$t" "$out/corpus/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=262144 \
    -artifact_prefix="$out/artifacts/$t/" -print_final_stats=1 > "$log" 2>&1
  rc=$?
  set -e
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  corpus=$(ls "$out/corpus/$t" | wc -l)
  crashes=$(ls "$out/artifacts/$t" | wc -l)
  line="$t: $(( $(date +%s) - start )) s, $runs executions, corpus $corpus files, $crashes crash/timeout/oom artifacts, exit $rc"
  echo "$line" | tee -a "$out/summary.txt"
  [ "$rc" -eq 0 ] && [ "$crashes" -eq 0 ] || status=1
done
exit $status
