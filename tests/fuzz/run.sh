#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Builds vd's libFuzzer harnesses with clang (-fsanitize=fuzzer,address,undefined; every object of
# libvd and vd_port instrumented) and runs each for a bounded time on a copy of its committed seed
# corpus. Prints executions and seconds per fuzzer; fails on any finding (the crashing input is left
# in $FUZZ_OUT/<target>/ — copy it to tests/fuzz/regressions/<target>/ so CTest replays it).
#
# Environment: FUZZ_SECONDS (per fuzzer, default 60), FUZZ_TARGETS (default: every harness built;
# names with or without the fuzz_ prefix, e.g. "detector cnn"; none built is an error), FUZZ_BUILD_DIR
# (default build-fuzz), FUZZ_OUT (default $FUZZ_BUILD_DIR/fuzz-out), FUZZ_JOBS (build -j, default 2),
# FUZZ_CFLAGS (added to the compile flags; e.g. -DVD_CNN_X86_MAX_LEVEL=2u fuzzes the AVX-VNNI kernels, and =1u
# AVX2's, on a CPU that would run AVX-512 ones; give such a build its own FUZZ_BUILD_DIR).
set -euo pipefail
cd "$(dirname "$0")/../.."
secs=${FUZZ_SECONDS:-60}
bdir=${FUZZ_BUILD_DIR:-build-fuzz}
out=${FUZZ_OUT:-$bdir/fuzz-out}
jobs=${FUZZ_JOBS:-2}
flags="-g -O1 -fno-omit-frame-pointer -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all -DVD_ASSERT_ENABLE ${FUZZ_CFLAGS:-}"

cmake -S . -B "$bdir" -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_COMPILER=clang -DVD_FUZZ=ON \
  -DVD_BUILD_TOOLS=OFF -DCMAKE_C_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined" >/dev/null
harnesses=$(cd tests/fuzz && ls fuzz_*.c | sed 's/^fuzz_\(.*\)\.c$/\1/' | tr '\n' ' ')
targets=${FUZZ_TARGETS:-$harnesses}
built=()
for t in $targets; do
  t=${t#fuzz_}   # FUZZ_TARGETS may name a harness with or without its fuzz_ prefix
  # (no grep -q: with pipefail, an early grep exit would fail the pipeline)
  if ninja -C "$bdir" -t targets all 2>/dev/null | grep "^fuzz_$t:" >/dev/null; then
    built+=("$t")
  else
    echo "fuzz: no target fuzz_$t in this configuration (module missing?) - skipped"
  fi
done
if [ ${#built[@]} -eq 0 ]; then
  # (else cmake --build --target gets no name and prints only its usage)
  echo "fuzz: none of the targets ($targets) is built in $bdir; the harnesses are: $harnesses"
  exit 1
fi
if ! cmake --build "$bdir" -j "$jobs" --target "${built[@]/#/fuzz_}" >"$bdir/fuzz-build.log" 2>&1; then
  tail -30 "$bdir/fuzz-build.log"
  echo "fuzz: build failed"
  exit 1
fi

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:allocator_may_return_null=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
fail=0
printf '%-12s %12s %8s %8s %8s  %s\n' target executions seconds exec/s corpus result
for t in "${built[@]}"; do
  work="$out/$t"
  rm -rf "$work"
  mkdir -p "$work/corpus"
  cp tests/fuzz/corpus/"$t"/* "$work/corpus/" 2>/dev/null || true
  seeds=$(ls "$work/corpus" | wc -l)
  dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  maxlen=4096
  [ "$t" = boost ] && maxlen=12288   # its seeds include models/vd_boost.vdm (11904 bytes)
  start=$(date +%s)
  set +e
  "$bdir/tests/fuzz/fuzz_$t" "$work/corpus" tests/fuzz/corpus/"$t" "${dict[@]}" \
    -max_total_time="$secs" -max_len="$maxlen" -rss_limit_mb=1024 -timeout=10 -print_final_stats=1 \
    -artifact_prefix="$work/" >"$work/log.txt" 2>&1
  rc=$?
  set -e
  end=$(date +%s)
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/log.txt" | tail -1)
  [ -n "$execs" ] || execs=0
  el=$((end - start))
  rate=$(( el > 0 ? execs / el : execs ))
  ncorp=$(ls "$work/corpus" | wc -l)
  if [ "$rc" -ne 0 ] || ls "$work"/crash-* "$work"/leak-* "$work"/timeout-* "$work"/oom-* >/dev/null 2>&1; then
    result="FINDING (log: $work/log.txt)"
    fail=1
  else
    result="ok"
  fi
  printf '%-12s %12s %8s %8s %4s->%-4s %s\n' "$t" "$execs" "$el" "$rate" "$seeds" "$ncorp" "$result"
  if [ "$result" != ok ]; then
    grep -E "ERROR|SUMMARY|invariant|#[0-9]+ 0x" "$work/log.txt" | head -20 || true
  fi
done
exit $fail
