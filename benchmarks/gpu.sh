#!/usr/bin/env bash
# The GPU figures in one run, for a machine with an NVIDIA GPU (the device machine): EGL bakes of the city's
# 165 spots at 8k and of a sun at 64k, and cpvs-view's 165-light flythrough at 1080p with 9x9 PCF.
# Needs a Release build with EGL in build/ (bash scripts/build.sh Release); writes out/gpu/gpu.md and gpu.json.
#   bash benchmarks/gpu.sh [extra benchmarks/gpu.py flags]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader || echo "nvidia-smi: no NVIDIA GPU found"
# Everything within 10 minutes: a stuck driver must not hold the machine.
timeout 590 python3 benchmarks/gpu.py "$@"
