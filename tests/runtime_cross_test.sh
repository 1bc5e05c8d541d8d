#!/usr/bin/env bash
# The runtime where engines ship it: its files (libcpvs/runtime/runtime_sources.cmake) and the example program
# cross-compiled (-Wall -Wextra -Werror, static, xxHash inlined) for Windows by MinGW-w64 and run under Wine,
# or for ARM64 by GCC's aarch64 cross compiler and run under qemu-user, answering exactly as the native Linux
# GCC build of the same example: two real bakes (TorusKnot under a sun and a spot; the generated city with 165
# spot lights at 1k) in format 2.0 and 3.0, unfiltered and with 9x9 PCF, and the golden files of
# formats/cpvs/golden (1.0, 2.0, 3.0). Windows writes text with CRLF line ends: the only difference allowed.
# On ARM64 every check runs twice, on the NEON path and on the scalar one (CPVS_LOOKUP_ISA=scalar). Then the
# runtime's own checks (tests/runtime_alone/runtime_checks.cpp), cross-compiled with GoogleTest, run on the same
# files under the same emulator.
# Skips (77) without the cross compiler or the emulator (scripts/install-deps.sh installs them).
# Usage: runtime_cross_test.sh windows|arm64 SOURCE_DIR BINARY_DIR WORK_DIR
set -euo pipefail
target=$1 src=$2 bin=$3/bin work=$4
case "$target" in
  windows)
    cxx=$(command -v x86_64-w64-mingw32-g++-posix || true)
    runner=$(command -v wine64 || ls /usr/lib/wine/wine64 2> /dev/null || true)
    program=cpvs-lookup-example.exe
    export WINEPREFIX="$work/wine" WINEDEBUG=-all;;
  arm64)
    cxx=$(command -v aarch64-linux-gnu-g++ || true)
    runner=$(command -v qemu-aarch64 || true)
    program=cpvs-lookup-example;;
  *) echo "usage: runtime_cross_test.sh windows|arm64 SOURCE_DIR BINARY_DIR WORK_DIR"; exit 2;;
esac
[ -n "$cxx" ] || { echo "no cross compiler for $target"; exit 77; }
[ -n "$runner" ] || { echo "no emulator for $target (wine64, qemu-user)"; exit 77; }
rm -rf "$work" && mkdir -p "$work/include"
# GLM and xxHash are header-only here: their headers alone, not the host's system headers.
ln -s /usr/include/glm "$work/include/glm"
ln -s /usr/include/xxhash.h "$work/include/xxhash.h"
sources=$(python3 - "$src/libcpvs/runtime/runtime_sources.cmake" <<'PY'
import os, re, sys
text = open(sys.argv[1]).read()
names = re.search(r"set\(_cpvs_runtime_files([^)]*)\)", text).group(1).split()
print(" ".join(os.path.join(os.path.dirname(sys.argv[1]), n + ".cpp") for n in names))
PY
)
# The runtime's files compiled once, then linked into the example and into the runtime's own checks
# (tests/runtime_alone/runtime_checks.cpp, with GoogleTest built from Debian's sources for the target).
gtest=/usr/src/googletest/googletest
[ -f "$gtest/src/gtest-all.cc" ] || { echo "no GoogleTest sources (libgtest-dev)"; exit 77; }
flags=(-std=c++20 -O2 -Wall -Wextra -Werror -ffp-contract=off -fno-math-errno -DXXH_INLINE_ALL -I"$src"
       -isystem "$work/include" -isystem "$gtest/include")
objects=()
for s in $sources "$src/examples/lookup/main.cpp" "$src/tests/runtime_alone/runtime_checks.cpp"; do
  o="$work/$(basename "$(dirname "$s")")-$(basename "$s" .cpp).o"
  "$cxx" "${flags[@]}" -c "$s" -o "$o"
  case "$s" in */main.cpp) example_main=$o;; */runtime_checks.cpp) checks_main=$o;; *) objects+=("$o");; esac
done
"$cxx" -std=c++20 -O1 -I"$gtest" -I"$gtest/include" -c "$gtest/src/gtest-all.cc" -o "$work/gtest-all.o"
checks=runtime_checks${program#cpvs-lookup-example}
"$cxx" -static -o "$work/$program" "$example_main" "${objects[@]}"
"$cxx" -static -o "$work/$checks" "$checks_main" "${objects[@]}" "$work/gtest-all.o" -pthread
# The cross build's paths: on ARM64 the NEON path (its best) and the scalar one, each against the native build.
paths=(best)
[ "$target" = arm64 ] && paths=(best scalar)
answers() {  # FILE.cpvs POINTS K OUT: the cross build's answers (CRLF made LF) and the native build's
  "$bin/cpvs-lookup-example" "$1" --pcf "$3" < "$2" > "$4.native"
  [ -s "$4.native" ] || { echo "no answers for $1"; exit 1; }
  for path in "${paths[@]}"; do
    isa=(); [ "$path" = best ] || isa=(env CPVS_LOOKUP_ISA="$path")
    "${isa[@]}" "$runner" "$work/$program" "$1" --pcf "$3" < "$2" 2> "$work/runner.log" | tr -d '\r' > "$4.$target"
    cmp "$4.$target" "$4.native" ||
      { echo "the $target build ($path path) answers $1 (K = $3) otherwise"; cat "$work/runner.log"; exit 1; }
  done
}
scene="$src/data/scenes/TorusKnot/torusknot.gltf"
lights=(--sun 0.3,-1,0.2 --spot 10,60,-30,-0.15,-0.85,0.5,0.6,200)
"$bin/cpvs-bake" "$scene" -r 512 "${lights[@]}" -o "$work/tk2.cpvs" --quiet
"$bin/cpvs-bake" "$scene" -r 512 "${lights[@]}" -o "$work/tk3.cpvs" --quiet --format-version 3
"$bin/cpvs-sample" "$scene" -o "$work/points.csv" --count 4000 > /dev/null
"$bin/cpvs-sample" "$src/data/scenes/Tiny/tiny.gltf" -o "$work/tiny-points.csv" --count 2000 > /dev/null
# The many-light benchmark level: 165 spot lights at 1k, both formats (3.0: every view reads one pool).
"$bin/cpvs-scenegen" city-spots --lights 165 -o "$work/spots165.glb" > /dev/null
"$bin/cpvs-bake" "$work/spots165.glb" -r 1k -o "$work/spots2.cpvs" --quiet
"$bin/cpvs-bake" "$work/spots165.glb" -r 1k -o "$work/spots3.cpvs" --quiet --format-version 3
"$bin/cpvs-sample" "$work/spots165.glb" -o "$work/spots-points.csv" --count 2000 > /dev/null
checked=0
for k in 1 9; do
  for v in 2 3; do answers "$work/tk$v.cpvs" "$work/points.csv" $k "$work/tk$v-$k"; checked=$((checked + 4000)); done
  for v in 2 3; do
    answers "$work/spots$v.cpvs" "$work/spots-points.csv" $k "$work/spots$v-$k"; checked=$((checked + 2000 * 165))
  done
  grep -q "=0" "$work/tk2-$k.native" && grep -q "=1" "$work/tk2-$k.native"  # the comparison means something
  for g in "$src"/formats/cpvs/golden/tiny_v*.cpvs; do
    answers "$g" "$work/tiny-points.csv" $k "$work/$(basename "$g" .cpvs)-$k"; checked=$((checked + 2000))
  done
done
echo "$target runtime ($(basename "$cxx") under $(basename "$runner"), paths: ${paths[*]}): $checked answers as the native build's, on each path"
# The runtime's own checks on the same files: every lookup path against one point at a time, damaged copies, the
# GPU records against the file's DAGs.
cases=("$work/tk2.cpvs" "$work/points.csv" "$work/tk3.cpvs" "$work/points.csv" "$work/spots2.cpvs"
       "$work/spots-points.csv" "$work/spots3.cpvs" "$work/spots-points.csv")
for g in "$src"/formats/cpvs/golden/tiny_v*.cpvs; do cases+=("$g" "$work/tiny-points.csv"); done
"$runner" "$work/$checks" --gtest_brief=1 "${cases[@]}" > "$work/checks.log" 2>&1 ||
  { echo "the $target build's runtime checks failed"; tr -d '\r' < "$work/checks.log"; exit 1; }
tr -d '\r' < "$work/checks.log" | grep -E "answers|copies|voxels|boundaries|PASSED"
