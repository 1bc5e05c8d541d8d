#!/usr/bin/env bash
# Configures and builds cpvs (Release by default) into build/: everything, or only the named targets.
# Usage: scripts/build.sh [BUILD_TYPE [TARGET...]]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build_type="${1:-Release}"
shift || true
# The Python module is built for Debian's interpreter, the one python3-numpy and python3-pybind11 belong to
# (another python3 first on PATH, e.g. a pyenv one, would not find them).
python=()
[ -x /usr/bin/python3 ] && python=(-DPython3_EXECUTABLE=/usr/bin/python3)
cmake -S "$root" -B "$root/build" -G Ninja -DCMAKE_BUILD_TYPE="$build_type" "${python[@]}" >/dev/null
ninja -C "$root/build" "$@"
