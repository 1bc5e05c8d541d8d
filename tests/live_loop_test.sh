#!/usr/bin/env bash
# The live loop (docs/pipelines.md, "Edit, bake, look"): cpvs-bake --watch bakes again when the scene is saved,
# each time the bytes of a clean bake of the saved scene; a save that does not import says why and leaves the
# output as it was; then, under a virtual X server, cpvs-view --window beside the watching bake shows an edit
# in its next frame after the re-bake (the window saved with P is the headless image of the edited scene).
# The window phase skips without xvfb-run, xdotool or a GLFW build.
set -euo pipefail
bin="$1"; source="$2"; work="$3"
rm -rf "$work" && mkdir -p "$work"
cd "$work"
cp "$source/data/scenes/Tiny/tiny.gltf" original.gltf
cp original.gltf live.gltf
# The helpers, in a file: the window phase's shell under xvfb-run sources them too.
cat > helpers.sh <<'SH'
# Saves the scene with its first node (a box) moved to X, as a DCC saves: a new file renamed over the old.
move() {
  python3 - "$1" <<'PY'
import json, os, sys
scene = json.load(open("original.gltf"))
scene["nodes"][0]["translation"][0] = float(sys.argv[1])
json.dump(scene, open("live.gltf.saving", "w"))
os.replace("live.gltf.saving", "live.gltf")
PY
}
# Waits (60 s at most) until FILE has N lines matching PATTERN.
wait_for() {
  for _ in $(seq 600); do
    [ "$(grep -c -- "$2" "$1" 2> /dev/null || true)" -ge "$3" ] && return 0
    sleep 0.1
  done
  echo "timed out waiting for $3 x '$2' in $1:"; cat "$1"; return 1
}
SH
source helpers.sh
watch_pid=""
trap '[ -n "$watch_pid" ] && kill "$watch_pid" 2> /dev/null; true' EXIT

"$bin/cpvs-bake" live.gltf --watch --resolution 64 -o live.cpvs > watch.log 2>&1 & watch_pid=$!
wait_for watch.log "watching live.gltf" 1
move -2.5
wait_for watch.log "watching live.gltf" 2
"$bin/cpvs-bake" live.gltf --resolution 64 -q -o clean.cpvs
cmp live.cpvs clean.cpvs || { echo "the watched re-bake differs from a clean bake of the saved scene"; exit 1; }
# A save that is not glTF: its message, and the output as it was.
echo "{ not json" > live.gltf.saving && mv live.gltf.saving live.gltf
wait_for watch.log "live.cpvs stays as it was" 1
cmp live.cpvs clean.cpvs || { echo "a failed re-bake changed the output"; exit 1; }
grep -q "live.gltf: the JSON cannot be parsed" watch.log || { echo "no message for the bad save"; cat watch.log; exit 1; }
move -2.0
wait_for watch.log "watching live.gltf" 4
"$bin/cpvs-bake" live.gltf --resolution 64 -q -o clean.cpvs
cmp live.cpvs clean.cpvs || { echo "the re-bake after the bad save differs from a clean bake"; exit 1; }
echo "cpvs-bake --watch: 3 saves, 2 re-bakes equal to clean bakes, the bad save refused"

command -v xvfb-run > /dev/null || { echo "xvfb-run not installed: the window phase is not tested"; exit 0; }
command -v xdotool > /dev/null || { echo "xdotool not installed: the window phase is not tested"; exit 0; }
window_env=(env "ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0")
cp "$source/tests/support/focus_window.sh" focus_window.sh
set +e
xvfb-run -a -s "-screen 0 800x600x24" "${window_env[@]}" bash -c '
  set -e
  source helpers.sh
  "$0" live.gltf live.cpvs --window --size 320x200 --exposure-scale 0.3 > window.log 2>&1 & pid=$!
  bash focus_window.sh > /dev/null || { echo "the window did not appear"; cat window.log; kill $pid; exit 1; }
  move 2.0
  wait_for watch.log "watching live.gltf" 5
  wait_for window.log "cpvs-view: reloaded" 1
  sleep 0.5
  xdotool key p
  for i in $(seq 300); do [ -f cpvs-view-0.png ] && break; sleep 0.1; done
  xdotool key q
  wait $pid' "$bin/cpvs-view"
rc=$?
set -e
cat window.log
if grep -q "without GLFW" window.log; then echo "no GLFW build: the window phase is not tested"; exit 0; fi
[ $rc -eq 0 ] || { echo "the window phase failed ($rc)"; exit 1; }
[ -f cpvs-view-0.png ] || { echo "P saved no window image"; exit 1; }
"$bin/cpvs-view" live.gltf live.cpvs --size 320x200 --exposure-scale 0.3 -q -o edited.png
"$bin/cpvs-view" live.gltf clean.cpvs --size 320x200 --exposure-scale 0.3 -q --no-scene-check -o before.png
python3 - "$source/tests/support" cpvs-view-0.png edited.png before.png <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
from png_pixels import differing, pixels
window, edited, before = (pixels(p)[2] for p in sys.argv[2:5])
print("window vs the edited scene's headless image: %d pixels differ; vs the scene before the edit: %d" %
      (differing(window, edited), differing(window, before)))
sys.exit(0 if differing(window, edited) == 0 and differing(window, before) > 100 else 1)
PY
