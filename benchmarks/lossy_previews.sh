#!/usr/bin/env bash
# The images of docs/lossy.md: the foliage level's sun at about the same bytes, lossless at a lower resolution
# beside lossy at a higher one (8k against 16k with `--max-voxel-error 16 --max-edge-error 2`, 16k against 64k
# with `--max-voxel-error 32 --max-edge-error 2`), with Embree's rays for reference; each with --compare (% wrong
# pixels against rays) and a --overlay difference twin, the CPU lookups (--shadows cpu: files of any size).
# Uses the bakes of `benchmarks/lossy.py` (and `--scenes foliage --lossless 8k --lossy 16k:16e2`) in its --out.
# Usage: benchmarks/lossy_previews.sh [BIN] [BAKES] [DOC] [TAG...]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="${1:-$root/build/bin}"
bakes="${2:-$root/out/lossy}"
doc="${3:-$root/docs/lossy}"
shift $(( $# < 3 ? $# : 3 ))
tags=("$@")
[ ${#tags[@]} -gt 0 ] || tags=(8k-lossless 16k-d16e2 16k-lossless 64k-d32e2)
mkdir -p "$doc"
scene="$bakes/foliage.glb"
# A clearing's edge: trunks, leaf cards, a building and the dappled shade on the ground.
view=(--size 960x540 --eye -57,3.5,19 --target -53,0.5,31 --pcf 3 --no-scene-check --shadows cpu)
for tag in "${tags[@]}"; do
  "$bin/cpvs-view" "$scene" "$bakes/foliage-$tag.cpvs" -o "$doc/forest-$tag.png" "${view[@]}" --compare \
    --report "$doc/forest-$tag.json"
  "$bin/cpvs-view" "$scene" "$bakes/foliage-$tag.cpvs" -o "$doc/forest-$tag-difference.png" "${view[@]}" \
    --overlay difference
done
"$bin/cpvs-view" "$scene" "$bakes/foliage-${tags[0]}.cpvs" -o "$doc/forest-raytraced.png" \
  --size 960x540 --eye -57,3.5,19 --target -53,0.5,31 --pcf 3 --no-scene-check --shadows raytraced
echo "images in $doc"
