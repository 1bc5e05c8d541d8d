#!/usr/bin/env bash
# Waits (30 s at most) until cpvs-view's window is mapped and takes the focus; prints its id. The window exists
# before it is mapped, and focusing it then fails (BadMatch): slow builds (sanitizers) showed that. For the
# window tests under xvfb-run (preview_window_test.sh, live_loop_test.sh).
for i in $(seq 300); do
  id=$(xdotool search --onlyvisible --name cpvs-view 2> /dev/null | head -1)
  if [ -n "$id" ] && timeout 5 xdotool windowfocus --sync "$id" 2> /dev/null; then echo "$id"; exit 0; fi
  sleep 0.1
done
exit 1
