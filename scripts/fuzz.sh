#!/usr/bin/env bash
# Builds the libFuzzer targets under fuzz/ with clang (address + undefined sanitizers) in
# build-fuzz/, makes their seed corpora and runs each one for a while. See docs/fuzzing.md.
#
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     (default 60 s, every target)
#
# e.g. scripts/fuzz.sh 600 fuzz_ply fuzz_pcd. Per target, under build-fuzz/results/: <target>.log
# (libFuzzer's output) and <target>.summary (one line: seconds, execs, coverage, corpus, crashes);
# crashers, leaks and timeouts go to build-fuzz/artifacts/<target>/. The corpus grows in
# build-fuzz/corpus/<target>/ across runs. Environment: VDBMAP_FUZZ_BUILD_DIR (build-fuzz),
# VDBMAP_FUZZ_SKIP_BUILD=1 (run what is built, with the seeds made before),
# VDBMAP_FUZZ_KEEP_GOING=1 (libFuzzer's fork mode: go on after a crash, oom or timeout and keep
# each one, e.g. for a target whose known crashers cannot be fixed yet),
# VDBMAP_JOBS (compile jobs, at most 4), VDBMAP_SHARED_DATA (seed files, default ../shared/data).
# Exit status: 0 when no target found anything, 1 otherwise.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

seconds="${1:-60}"
[ $# -gt 0 ] && shift
case "$seconds" in ''|*[!0-9]*) echo "usage: $0 [SECONDS_PER_TARGET] [TARGET...]" >&2; exit 2 ;; esac

# The same helper as the normal build; clang's libFuzzer and sanitizer runtimes come with
# libclang-rt-14-dev (libfuzzer-14-dev holds libFuzzer's headers and standalone library).
vdbmap_install_packages clang-14 libclang-rt-14-dev

# Sanitizer findings end the run with a report; leaks are findings too. Symbolized traces need
# llvm-symbolizer (clang's package ships it).
export ASAN_OPTIONS="abort_on_error=1:detect_leaks=1:symbolize=1:allocator_may_return_null=0${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$vdbmap_root/cmake/ubsan_suppressions.txt${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
symbolizer=$(command -v llvm-symbolizer-14 || command -v llvm-symbolizer || true)
[ -n "$symbolizer" ] && export ASAN_SYMBOLIZER_PATH="$symbolizer"
# A per-run scratch folder for the targets' temporary files (fuzz/fuzz_support.hpp).
export TMPDIR="${TMPDIR:-/tmp}"

fuzz_build="${VDBMAP_FUZZ_BUILD_DIR:-$vdbmap_root/build-fuzz}"
if [ -z "${VDBMAP_FUZZ_SKIP_BUILD:-}" ]; then
  clangxx=$(command -v clang++-14 || command -v clang++)
  if [ ! -f "$fuzz_build/CMakeCache.txt" ]; then
    # RelWithDebInfo: optimised (so that the fuzzer runs fast) with line numbers in stack traces.
    # VDBMAP_FUZZ adds -fsanitize=fuzzer-no-link to every library and -fsanitize=fuzzer to the
    # targets; VDBMAP_SANITIZE adds address,undefined (UB aborts) to everything.
    cmake -S "$vdbmap_root" -B "$fuzz_build" -G Ninja -DCMAKE_CXX_COMPILER="$clangxx" \
      -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVDBMAP_FUZZ=ON -DVDBMAP_SANITIZE="address;undefined" \
      -DVDBMAP_BUILD_TESTS=OFF -DVDBMAP_BUILD_BENCHMARKS=OFF -DVDBMAP_BUILD_PYTHON=OFF \
      > "$fuzz_build.configure.log" 2>&1 ||
      { cat "$fuzz_build.configure.log"; rm -f "$fuzz_build/CMakeCache.txt"; exit 1; }
  fi
  cmake --build "$fuzz_build" -j "$vdbmap_jobs" --target fuzz_all
fi
all_targets=$(cd "$fuzz_build/bin" && ls fuzz_* | grep -v '^fuzz_make_' | sort)
targets=("$@")
[ ${#targets[@]} -eq 0 ] && read -r -a targets <<< "$(echo $all_targets)"
# fuzz_vdb last: it runs OpenVDB's own reader, the slowest and most likely to stop early.
ordered=()
for t in "${targets[@]}"; do [ "$t" != fuzz_vdb ] && ordered+=("$t"); done
for t in "${targets[@]}"; do [ "$t" = fuzz_vdb ] && ordered+=("$t"); done

[ -z "${VDBMAP_FUZZ_SKIP_BUILD:-}" ] &&
  /usr/bin/python3 "$vdbmap_root/fuzz/make_corpus.py" "$fuzz_build/seeds" --vdb-generator "$fuzz_build/bin/fuzz_make_vdb_seed"

results="$fuzz_build/results"
mkdir -p "$results"

status=0
for t in "${ordered[@]}"; do
  bin="$fuzz_build/bin/$t"
  [ -x "$bin" ] || { echo "== $t: no such target (have: $(echo $all_targets))" >&2; status=1; continue; }
  corpus="$fuzz_build/corpus/$t"
  artifacts="$fuzz_build/artifacts/$t"
  mkdir -p "$corpus" "$artifacts"
  seeds=()
  [ -d "$fuzz_build/seeds/$t" ] && seeds+=("$fuzz_build/seeds/$t")
  [ -d "$vdbmap_root/fuzz/seeds/$t" ] && seeds+=("$vdbmap_root/fuzz/seeds/$t")
  # Fixed crashers seed the run; libFuzzer reads folders recursively, so a folder that also holds
  # open (unfixed) crashers is left out unless the run goes on after crashes.
  if [ -d "$vdbmap_root/fuzz/regressions/$t" ]; then
    if [ -d "$vdbmap_root/fuzz/regressions/$t/open" ] && [ -z "${VDBMAP_FUZZ_KEEP_GOING:-}" ]; then
      echo "== $t: fuzz/regressions/$t/ holds open crashers: not used as seeds (VDBMAP_FUZZ_KEEP_GOING=1 uses them)"
    else
      seeds+=("$vdbmap_root/fuzz/regressions/$t")
    fi
  fi
  echo "== $t: ${seconds} s"
  start=$(date +%s)
  # -timeout: one input running longer is a hang; -rss_limit_mb / -malloc_limit_mb: more than
  # 1 GiB in all or in one allocation is a finding. New inputs go to the first folder (corpus).
  keep_going=()
  [ -n "${VDBMAP_FUZZ_KEEP_GOING:-}" ] && keep_going=(-fork=1 -ignore_crashes=1 -ignore_ooms=1 -ignore_timeouts=1)
  set +e
  nice -n 19 "$bin" "$corpus" "${seeds[@]}" -max_total_time="$seconds" -rss_limit_mb=1024 -malloc_limit_mb=1024 \
    -timeout=10 -max_len=65536 -print_final_stats=1 -artifact_prefix="$artifacts/" "${keep_going[@]}" \
    > "$results/$t.log" 2>&1
  rc=$?
  set -e
  elapsed=$(( $(date +%s) - start ))
  # libFuzzer's last status line ("#N DONE cov: C ft: F corp: K/S ...") and its final stats.
  last=$(grep -E '^#[0-9]+' "$results/$t.log" | tail -n 1 || true)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$results/$t.log" | tail -n 1)
  [ -z "$execs" ] && execs=$(echo "$last" | sed -n 's/^#\([0-9]*\).*/\1/p')  # fork mode: no final stats
  cov=$(echo "$last" | sed -n 's/.* cov: \([0-9]*\).*/\1/p')
  ft=$(echo "$last" | sed -n 's/.* ft: \([0-9]*\).*/\1/p')
  corp=$(echo "$last" | sed -n 's/.* corp: \([0-9]*\/[0-9]*[a-zA-Z]*\).*/\1/p')
  found=$(find "$artifacts" -type f -newermt "@$start" | wc -l)
  verdict=ok
  if [ $rc -ne 0 ] || [ "$found" -gt 0 ]; then verdict=FINDING; status=1; fi
  line="$t: ${elapsed} s, ${execs:-?} execs, cov ${cov:-?}, ft ${ft:-?}, corpus ${corp:-?}, new artifacts ${found}, exit ${rc}: ${verdict}"
  echo "$line" | tee "$results/$t.summary"
done
cat "$results"/*.summary > "$results/summary.txt"
exit $status
