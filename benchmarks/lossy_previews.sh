#!/usr/bin/env bash
# The images of docs/lossy.md: the foliage level's sun at about the same bytes, lossless at 8k beside lossy at
# 16k (`--max-voxel-error 16 --max-edge-error 2`), with Embree's rays for reference; each with --compare (% wrong
# pixels against rays) and a --overlay difference twin. cpvs-view uploads the DAGs to the GPU even for --shadows
# cpu, and llvmpipe allows 128 MiB per buffer: files past about 180 MB cannot be shown there. Uses the bakes of
# `benchmarks/lossy.py --scenes foliage --lossless 8k --lossy 16k:16e2` in its --out folder.
# Usage: benchmarks/lossy_previews.sh [BIN] [BAKES] [DOC] [LOSSLESS-TAG] [LOSSY-TAG]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bin="${1:-$root/build/bin}"
bakes="${2:-$root/out/lossy}"
doc="${3:-$root/docs/lossy}"
lossless="${4:-8k-lossless}"
lossy="${5:-16k-d16e2}"
mkdir -p "$doc"
scene="$bakes/foliage.glb"
# A clearing's edge: trunks, leaf cards and the dappled shade on the ground, near enough to see single voxels
# of an 8k sun (about 7 cm across here).
view=(--size 960x540 --eye -57,3.5,19 --target -53,0.5,31 --pcf 3 --no-scene-check)
for tag in "$lossless" "$lossy"; do
  "$bin/cpvs-view" "$scene" "$bakes/foliage-$tag.cpvs" -o "$doc/forest-$tag.png" "${view[@]}" --shadows cpu --compare \
    --report "$doc/forest-$tag.json"
  "$bin/cpvs-view" "$scene" "$bakes/foliage-$tag.cpvs" -o "$doc/forest-$tag-difference.png" "${view[@]}" \
    --shadows cpu --overlay difference
done
"$bin/cpvs-view" "$scene" "$bakes/foliage-$lossless.cpvs" -o "$doc/forest-raytraced.png" "${view[@]}" \
  --shadows raytraced
echo "images in $doc"
