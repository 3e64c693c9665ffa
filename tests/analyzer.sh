#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# GCC's static analyzer (-fanalyzer: use of uninitialised or NULL values, out-of-bounds accesses, use after
# free, double free, leaks) over every source of lib/, with the exact flags of the gcc build (its -Werror makes
# any finding fail the run); then over the host code that reads files, arguments and streams (port/ and its
# tests, the demo, the GStreamer element, the benchmarks) with every check but the heap-leak one: GCC 12 loses
# track of a pointer stored into a realloc'ed array and calls it leaked (three such reports in eval.c and
# file_capture.c, checked by hand on 2026-11-30); leaks there are LeakSanitizer's, in the ASan test build
# (tools/test.sh, detect_leaks=1). lib/ has no heap, so the library keeps the full set.
# Usage: tests/analyzer.sh [BUILD_DIR]   (a configured gcc build, default build).
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build}"
jobs=$(nproc 2>/dev/null || echo 2)
all=$(ninja -C "$build" -t commands)

# The compile commands of sources matching $1, each once, without object and dependency outputs, with
# -fanalyzer and $2 after the compiler.
commands() {
  printf '%s\n' "$all" | grep -E " -c [^ ]*/($1)/[^ ]*\.c$" | awk '!seen[$NF]++' |
    sed -E 's/ -MD| -MT [^ ]+| -MF [^ ]+//g; s/ -o [^ ]+/ -o \/dev\/null/' |
    sed -E "s/^([^ ]+) /\1 -fanalyzer $2/" || true
}

commands 'lib/src' '' > "$build/analyzer_cmds.txt"
n_lib=$(grep -c . "$build/analyzer_cmds.txt" || true)
commands 'port|tools/demo|tools/gst|tools/bench' '-Wno-analyzer-malloc-leak ' > "$build/analyzer_host_cmds.txt"
n_host=$(grep -c . "$build/analyzer_host_cmds.txt" || true)
if [ "$n_lib" -lt 40 ] || [ "$n_host" -lt 15 ]; then
  echo "analyzer: found $n_lib compile commands of lib/ and $n_host of the host code in $build" \
       "(expected 40 and 15 or more)" >&2
  exit 1
fi
status=0
cat "$build/analyzer_cmds.txt" "$build/analyzer_host_cmds.txt" | xargs -P "$jobs" -d '\n' -I{} sh -c '{}' || status=$?
if [ "$status" -ne 0 ]; then
  echo "analyzer: findings above (or a source failed to compile)" >&2
  exit 1
fi
echo "analyzer: $n_lib sources of lib/ and $n_host of the host code (port/ and its tests, the demo, the element, the benchmarks), no finding"
