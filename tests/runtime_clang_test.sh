#!/usr/bin/env bash
# The runtime as an engine vendors it: its files (libcpvs/runtime/runtime_sources.cmake) and the example
# program compiled by clang on their own (-Wall -Wextra -Werror), answering exactly as the GCC build of the
# same example on points sampled from a real bake, unfiltered and with 9x9 PCF.
# Usage: runtime_clang_test.sh SOURCE_DIR BINARY_DIR WORK_DIR
set -euo pipefail
src=$1 bin=$2/bin work=$3
rm -rf "$work" && mkdir -p "$work"
CC=clang CXX=clang++ cmake -S "$src/examples/lookup" -B "$work/build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
ninja -C "$work/build" >/dev/null
clang_example="$work/build/cpvs-lookup-example"
scene="$src/data/scenes/TorusKnot/torusknot.gltf"
"$bin/cpvs-bake" "$scene" -r 512 --sun 0.3,-1,0.2 --spot 10,60,-30,-0.15,-0.85,0.5,0.6,200 -o "$work/tk.cpvs" --quiet
"$bin/cpvs-sample" "$scene" -o "$work/points.csv" --count 4000 >/dev/null
for k in 1 9; do
  "$bin/cpvs-lookup-example" "$work/tk.cpvs" --pcf $k < "$work/points.csv" > "$work/gcc-$k.txt"
  "$clang_example" "$work/tk.cpvs" --pcf $k < "$work/points.csv" > "$work/clang-$k.txt"
  lines=$(wc -l < "$work/gcc-$k.txt")
  [ "$lines" -eq 4000 ] || { echo "expected 4000 answers, got $lines"; exit 1; }
  cmp "$work/gcc-$k.txt" "$work/clang-$k.txt" || { echo "clang and GCC builds differ (K = $k)"; exit 1; }
  # Not all lit, not all shadowed: the comparison means something.
  grep -q "=0" "$work/gcc-$k.txt" && grep -q "=1" "$work/gcc-$k.txt"
done
echo "clang runtime: 2 x 4000 points answered as by the GCC build"
