#!/usr/bin/env bash
# Configures and builds cpvs (Release by default) into build/: everything, or only the named targets.
# Usage: scripts/build.sh [BUILD_TYPE [TARGET...]]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build_type="${1:-Release}"
shift || true
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE="$build_type" >/dev/null
ninja -C "$root/build" "$@"
