#!/usr/bin/env bash
# Builds the whole project with AddressSanitizer and UndefinedBehaviorSanitizer into build-sanitize/ and runs
# the test suite there (CI runs it after the normal suite). Any sanitizer report fails the test it happens in.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
bash "$root/scripts/install-deps.sh"
cmake -S "$root" -B "$root/build-sanitize" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCPVS_SANITIZE=ON \
  -DCPVS_BUILD_BENCHMARKS=OFF >/dev/null
ninja -C "$root/build-sanitize"
# Leaks: the GL driver (llvmpipe) and TBB keep process-lifetime allocations; they are listed in
# tests/sanitizer-suppressions/lsan.txt. halt_on_error: the first report fails the test.
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=0:detect_stack_use_after_return=0"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export LSAN_OPTIONS="suppressions=$root/tests/sanitizer-suppressions/lsan.txt:print_suppressions=0"
cd "$root/build-sanitize"
ctest --output-on-failure -j "$(nproc)" --timeout 900
