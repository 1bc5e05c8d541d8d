#!/usr/bin/env bash
# The preview images of docs/alpha.md: the generated foliage level (leaf cards alpha-tested, clear glass) and the
# MacrossCityDiorama as gltfpack ships it (meshopt-compressed; its BLEND glass clipped away), each with the CPVS
# shadows beside Embree's rays, at 960x540. Usage: benchmarks/alpha_previews.sh [BIN] [OUT] [DOC]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="${1:-$root/build/bin}"
out="${2:-$root/out/alpha-previews}"
doc="${3:-$root/docs/alpha}"
mkdir -p "$out" "$doc"

# Foliage: the sun at 8k; trees' dappled shadows from above a clearing, and the glass canopy by a building (its
# posts cast shadows, its clear glass none).
"$bin/cpvs-scenegen" foliage -o "$out/foliage.glb"
"$bin/cpvs-bake" "$out/foliage.glb" -o "$out/foliage-sun.cpvs" -r 8k --lights sun --quiet
"$bin/cpvs-bake" "$out/foliage.glb" -o "$out/foliage-sun-solid.cpvs" -r 8k --lights sun --alpha-test off --quiet
view=(--size 960x540 --eye -64,14,6 --target -56,0,22 --pcf 3 --no-scene-check)
"$bin/cpvs-view" "$out/foliage.glb" "$out/foliage-sun.cpvs" -o "$doc/foliage-cpvs.png" "${view[@]}"
"$bin/cpvs-view" "$out/foliage.glb" "$out/foliage-sun.cpvs" -o "$doc/foliage-raytraced.png" "${view[@]}" \
  --shadows raytraced
"$bin/cpvs-view" "$out/foliage.glb" "$out/foliage-sun-solid.cpvs" -o "$doc/foliage-alpha-off.png" "${view[@]}" \
  --alpha-test off
"$bin/cpvs-view" "$out/foliage.glb" "$out/foliage-sun.cpvs" -o "$doc/foliage-canopy.png" --size 960x540 \
  --eye -68,7,-6 --target -84,1,9 --pcf 3 --no-scene-check
"$bin/cpvs-view" "$out/foliage.glb" "$out/foliage-sun.cpvs" -o "$doc/foliage-overview.png" --size 960x540 \
  --no-scene-check

# The diorama straight from its compressed .glb, lit by a sun at 4k.
diorama="$root/data/scenes/MacrossCityDiorama/scene.glb"
"$bin/cpvs-bake" "$diorama" -o "$out/macross.cpvs" -r 4k --sun 0.35,-1,0.45 --quiet
view=(--size 960x540 --eye 1.2,0.9,2.6 --target -0.3,-0.3,-0.6)
"$bin/cpvs-view" "$diorama" "$out/macross.cpvs" -o "$doc/macross-cpvs.png" "${view[@]}"
"$bin/cpvs-view" "$diorama" "$out/macross.cpvs" -o "$doc/macross-raytraced.png" "${view[@]}" --shadows raytraced
echo "images in $doc"
