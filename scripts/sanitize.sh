#!/usr/bin/env bash
# Builds the core and io tests (vdbmap_tests), and the fuzz targets' replay tests, with
# AddressSanitizer and UndefinedBehaviorSanitizer (gcc) in build-asan/ and runs them through
# CTest; any sanitizer report fails its test. See docs/fuzzing.md.
#
#   scripts/sanitize.sh [--planner] [CTEST_ARGS...]
#
# --planner also builds and runs planner_tests. Prints the wall time of configure, build and
# tests, and writes it with CTest's verdict to build-asan/sanitize_summary.txt. Environment:
# VDBMAP_ASAN_BUILD_DIR (build-asan), VDBMAP_JOBS (compile jobs, at most 4).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

targets=(vdbmap_tests fuzz_replay_all)
test_regex='^(vdbmap:|fuzz_replay_)'
if [ "${1:-}" = "--planner" ]; then
  shift
  targets+=(planner_tests)
  test_regex='^(vdbmap:|planner:|fuzz_replay_)'
fi

vdbmap_install_packages
asan_build="${VDBMAP_ASAN_BUILD_DIR:-$vdbmap_root/build-asan}"

# Halt on the first report of either sanitizer, leaks included, with a stack trace; the exit
# code makes CTest mark the test failed. Exported before the build too: catch_discover_tests runs
# each test program once after linking to list its test cases.
export ASAN_OPTIONS="halt_on_error=1:abort_on_error=0:detect_leaks=1:detect_stack_use_after_return=1:strict_init_order=1:check_initialization_order=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:suppressions=$vdbmap_root/cmake/ubsan_suppressions.txt${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"

t0=$(date +%s)
if [ ! -f "$asan_build/CMakeCache.txt" ]; then
  # RelWithDebInfo: the tests integrate real frames, far too slow at -O0 under ASan; -g for traces.
  cmake -S "$vdbmap_root" -B "$asan_build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DVDBMAP_SANITIZE="address;undefined" -DVDBMAP_BUILD_TESTS=ON -DVDBMAP_BUILD_PYTHON=OFF \
    -DVDBMAP_BUILD_BENCHMARKS=OFF > "$asan_build.configure.log" 2>&1 ||
    { cat "$asan_build.configure.log"; rm -f "$asan_build/CMakeCache.txt"; exit 1; }
fi
t1=$(date +%s)
cmake --build "$asan_build" -j "$vdbmap_jobs" --target "${targets[@]}"
t2=$(date +%s)
set +e
(cd "$asan_build" && ctest -R "$test_regex" --output-on-failure -j "$vdbmap_jobs" "$@") | tee "$asan_build/ctest.log"
rc=${PIPESTATUS[0]}
set -e
t3=$(date +%s)

verdict=$(grep -E 'tests passed|tests failed' "$asan_build/ctest.log" | tail -n 1)
summary="sanitizers address+undefined (gcc, RelWithDebInfo), ${targets[*]}: configure $((t1 - t0)) s, build $((t2 - t1)) s, tests $((t3 - t2)) s, total $((t3 - t0)) s wall; ${verdict:-no CTest verdict} (ctest exit $rc)"
echo "$summary" | tee "$asan_build/sanitize_summary.txt"
exit $rc
