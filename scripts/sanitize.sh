#!/usr/bin/env bash
# Builds build-asan/ with AddressSanitizer and UndefinedBehaviorSanitizer (RIG_SANITIZE=ON, RelWithDebInfo;
# undefined behaviour stops the program) and runs the whole test suite through CTest, the command lines
# the tests start included. Any sanitizer report fails the test that triggered it.
# Usage: scripts/sanitize.sh [CTEST ARGS...]   e.g. scripts/sanitize.sh -R corpus
#   $RIG_ASAN_BUILD_DIR: another build folder; $RIG_JOBS: parallel compile and test jobs (default: all cores).
# Time on a 2-core machine: see docs/robustness.md.
set -euo pipefail
cd "$(dirname "$0")/.."

build=${RIG_ASAN_BUILD_DIR:-build-asan}
jobs=${RIG_JOBS:-$(nproc)}

start=$(date +%s)
if [ ! -f "$build/build.ninja" ]; then
  cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRIG_SANITIZE=ON >/dev/null
fi
if ! cmake --build "$build" -- -j"$jobs" >"$build/build.log" 2>&1; then
  grep -E 'error|FAILED' "$build/build.log" | head -20 >&2
  echo "sanitize: the build failed; see $build/build.log" >&2
  exit 2
fi
built=$(date +%s)

# Reports go to standard error, where the tests' exact-message checks see them; a leak or an error ends
# the process with a failure.
asan_defaults=detect_leaks=1:abort_on_error=0:strict_string_checks=1:detect_stack_use_after_return=1
export ASAN_OPTIONS=${ASAN_OPTIONS:-$asan_defaults}
# scripts/ubsan.supp: reports inside Debian's oneTBB headers, not in this project's code.
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1:suppressions=$PWD/scripts/ubsan.supp}
status=0
ctest --test-dir "$build" --output-on-failure -j"$jobs" "$@" || status=$?
done_at=$(date +%s)
echo "sanitize: build $((built - start)) s, tests $((done_at - built)) s" >&2
exit "$status"
