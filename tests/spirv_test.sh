#!/usr/bin/env bash
# The runtime's GLSL for Vulkan: libcpvs/runtime/cpvs_visibility.comp (which includes every GLSL file of the
# runtime, as an engine would) compiles to SPIR-V with glslangValidator and passes spirv-val, for Vulkan 1.1 and
# 1.2; and no GLSL file of the runtime is left out of it. Skips (77) without glslang-tools or spirv-tools
# (scripts/install-deps.sh installs both).
set -euo pipefail
source="$1"; work="$2"
command -v glslangValidator > /dev/null || { echo "glslangValidator not installed (glslang-tools)"; exit 77; }
command -v spirv-val > /dev/null || { echo "spirv-val not installed (spirv-tools)"; exit 77; }
rm -rf "$work" && mkdir -p "$work"
runtime="$source/libcpvs/runtime"
shader="$runtime/cpvs_visibility.comp"
for file in "$runtime"/*.glsl "$runtime"/*.glsl.h; do
  name=$(basename "$file")
  grep -q "^#include \"$name\"" "$shader" || { echo "$name is not included by cpvs_visibility.comp"; exit 1; }
done
for env in vulkan1.1 vulkan1.2; do
  glslangValidator -V --target-env "$env" -I"$runtime" -o "$work/cpvs_visibility-$env.spv" "$shader"
  spirv-val --target-env "$env" "$work/cpvs_visibility-$env.spv"
  echo "cpvs_visibility.comp: valid SPIR-V for $env ($(stat -c %s "$work/cpvs_visibility-$env.spv") bytes)"
done
