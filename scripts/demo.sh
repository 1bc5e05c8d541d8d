#!/usr/bin/env bash
# Installs what is missing, builds Release, and bakes the bundled SubpassSceneOpaque scene (arcades, vaults,
# a dome and a Menger sponge) for a sun and a spot light, then inspects and queries the result and renders a
# preview image of it.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/scripts/install-deps.sh"
# Only the tools the demo runs (the test suite builds the rest: scripts/test.sh).
bash "$root/scripts/build.sh" Release cpvs-info cpvs-bake cpvs-sample cpvs-query cpvs-view

bin="$root/build/bin"
out="$root/out/demo"
scene="$root/data/scenes/SubpassSceneOpaque/subpass_scene_opaque.gltf"
rm -rf "$out"
mkdir -p "$out"

# The scene is authored with -Y up, so a sun that travels "down" travels toward +Y. The spot (40 cd) lights
# the corner of the arcades the sun leaves in shadow; the preview looks from the side the sun lights (its
# default camera, docs/viewer.md), through the arcades into their shade.
lights=(--sun 0.35,1,0.25 --spot 9,-6,9,-5,6.5,-5,0.7,30,40)

echo
echo "== The scene (and the input hash the bake below will record) =="
"$bin/cpvs-info" "$scene" "${lights[@]}" --resolution 4k

echo
echo "== Baking at 4k (a sun and a spot light) =="
"$bin/cpvs-bake" "$scene" "${lights[@]}" --resolution 4k -o "$out/subpass.cpvs" \
  --report "$out/bake-report.json" --dump-depth "$out/depth"

echo
echo "== What the file holds =="
"$bin/cpvs-info" "$out/subpass.cpvs"

echo
echo "== Querying 20000 surface points, checked against Embree ray tracing =="
"$bin/cpvs-sample" "$scene" -o "$out/points.csv" --count 20000
"$bin/cpvs-query" "$out/subpass.cpvs" --points "$out/points.csv" -o "$out/visibility.csv" --pcf 3 \
  --reference "$scene" --report "$out/query-report.json"

echo
echo "== A preview of the bake (cpvs-view: 9x9 PCF, walked on the GPU where there is one, else by the CPU runtime) =="
"$bin/cpvs-view" "$scene" "$out/subpass.cpvs" --up 0,-1,0 --size 1280x720 -o "$out/preview.png" --compare \
  --report "$out/view-report.json"

echo
echo "Outputs are in $out:"
echo "  subpass.cpvs         the baked shadows (inspect with build/bin/cpvs-info)"
echo "  bake-report.json     timings per phase, nodes per level, bytes vs a 16-bit shadow map"
echo "  depth/*.exr          enter/exit depth maps in slice units, one per light, view and 1k region (any EXR viewer)"
echo "  points.csv           the sampled surface points (x,y,z,nx,ny,nz)"
echo "  visibility.csv       one column per light, one row per point, in [0, 1] (3x3 PCF)"
echo "  query-report.json    lookup throughput and error against Embree"
echo "  preview.png          the scene lit by both lights with their CPVS shadows (1280x720, 9x9 PCF)"
echo "  view-report.json     the preview's pass times, light lists and error against Embree rays"
exit 0
