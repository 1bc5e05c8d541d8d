#!/usr/bin/env bash
# cpvs-view --window under a virtual X server (xvfb-run): the window opens, shows the first frame, and its own
# pixels (--screenshot) are the headless renderer's image of the same view; then, with keys typed by xdotool
# (4: no shadows, O: the next overlay, P: save the window), the saved window is the headless image with those
# settings; a left drag of 100 pixels to the right turns the view by 1 radian about the up axis (the saved
# window is the headless image from the turned eye). Skips (77) without xvfb-run or without a GLFW build; the
# key and mouse phases need xdotool.
set -euo pipefail
bin="$1"; source="$2"; work="$3"
command -v xvfb-run > /dev/null || { echo "xvfb-run not installed (scripts/install-deps.sh installs xvfb)"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
scene="$source/data/scenes/Tiny/tiny.gltf"
# Under AddressSanitizer (scripts/test-sanitized.sh) the windowed runs keep every check but the leak check:
# the X and GLX libraries behind GLFW keep a few hundred bytes for the process's life, which LeakSanitizer
# reports without naming the library (so tests/sanitizer-suppressions/lsan.txt cannot match them).
window_env=(env "ASAN_OPTIONS=${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0")
"$bin/cpvs-bake" "$scene" --resolution 128 -q -o "$work/tiny.cpvs"
set +e
xvfb-run -a -s "-screen 0 800x600x24" "${window_env[@]}" "$bin/cpvs-view" "$scene" "$work/tiny.cpvs" --window --size 320x200 \
  --exposure-scale 0.3 --screenshot "$work/window.png" > "$work/window.log" 2>&1
rc=$?
set -e
cat "$work/window.log"
if [ $rc -eq 5 ] && grep -q "without GLFW" "$work/window.log"; then exit 77; fi
[ $rc -eq 0 ] || { echo "cpvs-view --window exited with $rc"; exit 1; }
"$bin/cpvs-view" "$scene" "$work/tiny.cpvs" --size 320x200 --exposure-scale 0.3 -q -o "$work/headless.png"
# The window shows what the headless path writes, pixel for pixel.
cat > "$work/same_pixels.py" <<PY
import sys
sys.path.insert(0, "$source/tests/support")
from png_pixels import differing, pixels
wa, ha, a = pixels(sys.argv[1]); wb, hb, b = pixels(sys.argv[2])
allowed = int(sys.argv[3]) if len(sys.argv) > 3 else 0  # differing pixels allowed
assert (wa, ha) == (wb, hb) == (320, 200), ((wa, ha), (wb, hb))
lit = sum(1 for i in range(0, len(a), 3) if max(a[i:i + 3]) > 40)
print("window vs headless: %d of %d pixels differ, %d bright pixels" % (differing(a, b), wa * ha, lit))
sys.exit(0 if differing(a, b) <= allowed and lit > 1000 else 1)
PY
python3 "$work/same_pixels.py" "$work/window.png" "$work/headless.png"

command -v xdotool > /dev/null || { echo "xdotool not installed: the keys are not tested"; exit 0; }
focus="$source/tests/support/focus_window.sh"
(cd "$work" && rm -f cpvs-view-0.png && xvfb-run -a -s "-screen 0 800x600x24" "${window_env[@]}" bash -c '
  "$0" "$1" "$2" --window --size 320x200 --exposure-scale 0.3 & pid=$!
  id=$(bash "$3") || { echo "the window did not appear"; kill $pid; exit 1; }
  xdotool key 4 o p
  for i in $(seq 300); do [ -f cpvs-view-0.png ] && break; sleep 0.1; done
  xdotool key q
  wait $pid' "$bin/cpvs-view" "$scene" "$work/tiny.cpvs" "$focus")
[ -f "$work/cpvs-view-0.png" ] || { echo "P saved no window image"; exit 1; }
"$bin/cpvs-view" "$scene" "$work/tiny.cpvs" --size 320x200 --exposure-scale 0.3 --shadows none \
  --overlay lights-per-tile -q -o "$work/headless-keys.png"
python3 "$work/same_pixels.py" "$work/cpvs-view-0.png" "$work/headless-keys.png"

# The mouse: a drag 100 pixels right yaws the eye -1 radian about up (0.01 radian a pixel) around the target.
"$bin/cpvs-view" "$scene" "$work/tiny.cpvs" --size 320x200 --exposure-scale 0.3 -q -o "$work/unturned.png" \
  --report "$work/unturned.json"
(cd "$work" && rm -f cpvs-view-0.png && xvfb-run -a -s "-screen 0 800x600x24" "${window_env[@]}" bash -c '
  "$0" "$1" "$2" --window --size 320x200 --exposure-scale 0.3 & pid=$!
  id=$(bash "$3") || { echo "the window did not appear"; kill $pid; exit 1; }
  xdotool mousemove --window "$id" --sync 100 100 mousedown 1
  xdotool mousemove_relative --sync 100 0 mouseup 1 key p
  for i in $(seq 300); do [ -f cpvs-view-0.png ] && break; sleep 0.1; done
  xdotool key q
  wait $pid' "$bin/cpvs-view" "$scene" "$work/tiny.cpvs" "$focus")
[ -f "$work/cpvs-view-0.png" ] || { echo "P saved no window image after the drag"; exit 1; }
turned=$(python3 - "$work/unturned.json" <<'PY'
import json, math, sys
camera = json.load(open(sys.argv[1]))["frames"][0]["camera"]
eye, target = camera["eye"], camera["target"]
yaw = -1.0  # about up = +Y: x' = x cos + z sin, z' = -x sin + z cos
d = [eye[i] - target[i] for i in range(3)]
x, z = d[0] * math.cos(yaw) + d[2] * math.sin(yaw), -d[0] * math.sin(yaw) + d[2] * math.cos(yaw)
turned = [target[0] + x, eye[1], target[2] + z]
print("--eye=%r,%r,%r --target=%r,%r,%r" % (*turned, *target))
PY
)
# shellcheck disable=SC2086
"$bin/cpvs-view" "$scene" "$work/tiny.cpvs" --size 320x200 --exposure-scale 0.3 $turned -q -o "$work/headless-turned.png"
# The drag may arrive as several motion events (rotations that add up to the same angle, rounded apart):
# a few edge pixels may differ.
python3 "$work/same_pixels.py" "$work/cpvs-view-0.png" "$work/headless-turned.png" 64
# And the turn is visible: the unturned image is not it.
if python3 "$work/same_pixels.py" "$work/cpvs-view-0.png" "$work/unturned.png" 640 > /dev/null; then
  echo "the drag did not turn the view"; exit 1
fi
