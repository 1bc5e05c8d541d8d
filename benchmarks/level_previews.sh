#!/usr/bin/env bash
# The images of docs/viewer.md, "Three real levels": the two bundled dioramas and the generated foliage level,
# each lit by a sun and local lights, baked at 8k and previewed with the defaults (the camera on the side the
# strongest light lights, the fill, 9x9 PCF, the CPU lookups), plus each with --overlay difference against
# Embree's rays; the foliage level also from a clearing's edge, where the dappled shade is.
# Usage: benchmarks/level_previews.sh [BIN] [OUT] [DOC]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="${1:-$root/build/bin}"
out="${2:-$root/out/level-previews}"
doc="${3:-$root/docs/viewer/levels}"
mkdir -p "$out" "$doc"
"$bin/cpvs-scenegen" foliage -o "$out/foliage.glb" >/dev/null

preview() {  # NAME SCENE [cpvs-view options...]
  local name="$1" scene="$2"
  shift 2
  "$bin/cpvs-view" "$scene" "$out/$name.cpvs" -o "$doc/$name.png" --size 960x540 --shadows cpu --compare \
    --report "$doc/$name.json" "$@"
  "$bin/cpvs-view" "$scene" "$out/$name.cpvs" -o "$doc/$name-difference.png" --size 960x540 --shadows cpu \
    --overlay difference -q "$@"
}

# The garden: an afternoon sun from one side, a lantern (point light) by the bridge, a spot on the left bank.
garden="$root/data/scenes/JapaneseBridgeGarden/scene.glb"
"$bin/cpvs-bake" "$garden" --sun 0.35,-1,0.45 --point 1.5,2.5,0.5,8,3 --spot -3,5,3,0.5,-1,-0.4,0.6,12,8 \
  --resolution 8k -q -o "$out/garden.cpvs"
preview garden "$garden"

# The city diorama: a sun, a street lamp (point) and a spot from above the left block.
city="$root/data/scenes/MacrossCityDiorama/scene.glb"
"$bin/cpvs-bake" "$city" --sun 0.4,-1,0.3 --point 0.5,0.8,0.2,4,0.5 --spot -1.5,2.5,1.5,0.4,-1,-0.4,0.7,6,2 \
  --resolution 8k -q -o "$out/city.cpvs"
preview city "$city"

# The foliage level with its own sun and 16 spot lights.
"$bin/cpvs-bake" "$out/foliage.glb" --resolution 8k -q -o "$out/foliage.cpvs"
preview foliage "$out/foliage.glb"
cp "$out/foliage.cpvs" "$out/foliage-clearing.cpvs"
preview foliage-clearing "$out/foliage.glb" --eye -57,3.5,19 --target -53,0.5,31
echo "images in $doc"
