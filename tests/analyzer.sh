#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# GCC's static analyzer (-fanalyzer: use of uninitialised or NULL values, out-of-bounds accesses, leaks) over
# every source of lib/, with the exact flags of the gcc build (its -Werror makes any finding fail the run).
# Usage: tests/analyzer.sh [BUILD_DIR]   (a configured gcc build, default build). Outside lib/ (the demo and
# the port use the heap) the analyzer's findings were checked by hand on 2026-11-30 and are false positives
# (pointers kept in arrays it loses track of), so it runs on the library only.
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build}"
jobs=$(nproc 2>/dev/null || echo 2)
cmds=$(ninja -C "$build" -t commands vd | grep -E ' -c [^ ]*/lib/src/[^ ]*\.c$' || true)
n=$(printf '%s\n' "$cmds" | grep -c . || true)
if [ "$n" -lt 40 ]; then
  echo "analyzer: found $n compile commands of lib/ in $build (expected 40 or more)" >&2
  exit 1
fi
# Each command without its object and dependency outputs; -o /dev/null.
printf '%s\n' "$cmds" | sed -E 's/ -MD| -MT [^ ]+| -MF [^ ]+//g; s/ -o [^ ]+/ -o \/dev\/null/' |
  sed -E 's/^([^ ]+) /\1 -fanalyzer /' > "$build/analyzer_cmds.txt"
status=0
xargs -P "$jobs" -d '\n' -I{} sh -c '{}' < "$build/analyzer_cmds.txt" || status=$?
if [ "$status" -ne 0 ]; then
  echo "analyzer: findings above (or a source failed to compile)" >&2
  exit 1
fi
echo "analyzer: $n sources of lib/, no finding"
