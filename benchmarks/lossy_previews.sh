#!/usr/bin/env bash
# The images of docs/lossy.md: the foliage level's sun at about the same bytes, lossless at 16k beside lossy at
# 64k, with lossless 64k and Embree's rays for reference; each with --compare (% wrong pixels against rays) and
# a --overlay difference twin. Uses the bakes benchmarks/lossy.py left in its --out folder.
# Usage: benchmarks/lossy_previews.sh [BIN] [BAKES] [DOC] [LOSSY-TAG]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="${1:-$root/build/bin}"
bakes="${2:-$root/out/lossy}"
doc="${3:-$root/docs/lossy}"
lossy="${4:-64k-d32e2}"
mkdir -p "$doc"
scene="$bakes/foliage.glb"
# A clearing's edge: trunks, leaf cards and the dappled shade on the ground, near enough to see single voxels
# of a 16k sun (about 3.4 cm here).
view=(--size 960x540 --eye -60,6,12 --target -54,0,22 --pcf 3 --no-scene-check)
for tag in 16k-lossless "$lossy" 64k-lossless; do
  "$bin/cpvs-view" "$scene" "$bakes/foliage-$tag.cpvs" -o "$doc/forest-$tag.png" "${view[@]}" --compare \
    --report "$doc/forest-$tag.json"
  "$bin/cpvs-view" "$scene" "$bakes/foliage-$tag.cpvs" -o "$doc/forest-$tag-difference.png" "${view[@]}" \
    --overlay difference
done
"$bin/cpvs-view" "$scene" "$bakes/foliage-16k-lossless.cpvs" -o "$doc/forest-raytraced.png" "${view[@]}" \
  --shadows raytraced
echo "images in $doc"
