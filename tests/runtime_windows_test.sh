#!/usr/bin/env bash
# The runtime on Windows: its files (every .cpp of libcpvs/runtime/, as runtime_sources.cmake lists them) and the
# example program cross-compiled by MinGW-w64 (-Wall -Wextra -Werror, static, xxHash inlined), run under Wine,
# answering exactly as the Linux GCC build of the same example: a real bake in format 2.0 and its 3.0 twin,
# unfiltered and with 9x9 PCF, and the golden files of formats/cpvs/golden (1.0, 2.0, 3.0). Windows writes its
# text with CRLF line ends; they are the only difference allowed. Skips (77) without the cross compiler or
# Wine (scripts/install-deps.sh installs both).
# Usage: runtime_windows_test.sh SOURCE_DIR BINARY_DIR WORK_DIR
set -euo pipefail
src=$1 bin=$2/bin work=$3
cxx=$(command -v x86_64-w64-mingw32-g++-posix || true)
wine=$(command -v wine64 || ls /usr/lib/wine/wine64 2> /dev/null || true)
[ -n "$cxx" ] || { echo "no MinGW-w64 g++ (g++-mingw-w64-x86-64-posix)"; exit 77; }
[ -n "$wine" ] || { echo "no Wine (wine64)"; exit 77; }
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
"$cxx" -std=c++20 -O2 -Wall -Wextra -Werror -ffp-contract=off -fno-math-errno -DXXH_INLINE_ALL -I"$src" \
  -isystem "$work/include" -static -o "$work/cpvs-lookup-example.exe" "$src/examples/lookup/main.cpp" $sources
export WINEPREFIX="$work/wine" WINEDEBUG=-all
answers() {  # FILE.cpvs POINTS K OUT: the Windows build's answers, CRLF made LF, and the Linux build's
  "$wine" "$work/cpvs-lookup-example.exe" "$1" --pcf "$3" < "$2" 2> "$work/wine.log" | tr -d '\r' > "$4.windows"
  "$bin/cpvs-lookup-example" "$1" --pcf "$3" < "$2" > "$4.linux"
  [ -s "$4.linux" ] || { echo "no answers for $1"; exit 1; }
  cmp "$4.windows" "$4.linux" || { echo "the Windows build answers $1 (K = $3) otherwise than Linux"; cat "$work/wine.log"; exit 1; }
}
scene="$src/data/scenes/TorusKnot/torusknot.gltf"
lights=(--sun 0.3,-1,0.2 --spot 10,60,-30,-0.15,-0.85,0.5,0.6,200)
"$bin/cpvs-bake" "$scene" -r 512 "${lights[@]}" -o "$work/tk2.cpvs" --quiet
"$bin/cpvs-bake" "$scene" -r 512 "${lights[@]}" -o "$work/tk3.cpvs" --quiet --format-version 3
"$bin/cpvs-sample" "$scene" -o "$work/points.csv" --count 4000 > /dev/null
"$bin/cpvs-sample" "$src/data/scenes/Tiny/tiny.gltf" -o "$work/tiny-points.csv" --count 2000 > /dev/null
checked=0
for k in 1 9; do
  for v in 2 3; do answers "$work/tk$v.cpvs" "$work/points.csv" $k "$work/tk$v-$k"; checked=$((checked + 4000)); done
  grep -q "=0" "$work/tk2-$k.linux" && grep -q "=1" "$work/tk2-$k.linux"  # the comparison means something
  for g in "$src"/formats/cpvs/golden/tiny_v*.cpvs; do
    answers "$g" "$work/tiny-points.csv" $k "$work/$(basename "$g" .cpvs)-$k"; checked=$((checked + 2000))
  done
done
echo "Windows runtime (MinGW-w64 under Wine): $checked answers as the Linux build's"
