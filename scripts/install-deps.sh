#!/usr/bin/env bash
# Installs the Debian 12 packages cpvs needs to build, test and run. Only asks apt when one is missing.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config python3
  libembree-dev libopenexr-dev libtinygltf-dev libglm-dev
  libosmesa6-dev libegl-dev libegl-mesa0 libgl-dev
  libmeshoptimizer-dev libdraco-dev # compressed glTF (EXT_meshopt_compression, KHR_draco_mesh_compression)
  libgtest-dev libgmock-dev libbenchmark-dev
  nlohmann-json3-dev libcli11-dev libstb-dev libtbb-dev libxxhash-dev libjemalloc-dev
  assimp-testmodels clang libclang-rt-14-dev
  slurmctld slurmd slurm-client munge # the one-node cluster of scripts/slurm-local.sh (docs/pipelines.md)
  libglfw3-dev xvfb xauth xdotool # cpvs-view --window, and its test under a virtual X server (docs/viewer.md)
  glslang-tools spirv-tools libvulkan-dev mesa-vulkan-drivers # the runtime's GLSL as SPIR-V, validated and run on
                                                               # Vulkan (lavapipe without a GPU; docs/runtime.md)
  g++-mingw-w64-x86-64-posix wine64 g++-aarch64-linux-gnu qemu-user # the runtime cross-compiled for Windows
                                                                      # and ARM64, run under Wine and qemu
  python3-dev python3-pybind11 python3-numpy python3-pytest mypy # the Python module (python/, docs/python.md)
  libzstd-dev # the bake cache's region packs, compressed (docs/incremental-bakes.md)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then SUDO=sudo; else SUDO=; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
