#!/usr/bin/env bash
# Configures and builds cpvs (Release by default) into build/. Usage: scripts/build.sh [BUILD_TYPE]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build_type="${1:-Release}"
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE="$build_type" >/dev/null
ninja -C "$root/build"
