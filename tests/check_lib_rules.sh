#!/bin/sh
# SPDX-License-Identifier: MIT
# Fails if libvd.a references the heap or lib/ uses floating point.
# usage: check_lib_rules.sh LIBVD_A LIB_DIR [NM]
set -u
lib=$1; dir=$2; nm=${3:-nm}
[ -n "$nm" ] || nm=nm
rc=0
heap=$("$nm" -u "$lib" 2>/dev/null | awk '{print $NF}' | grep -E '^_?(malloc|calloc|realloc|free|aligned_alloc|posix_memalign)$')
if [ -n "$heap" ]; then echo "libvd.a references the heap: $heap"; rc=1; fi
fp=$("$nm" -u "$lib" 2>/dev/null | awk '{print $NF}' | grep -E '^_?(__aeabi_[fd]|__(add|sub|mul|div)[sd]f3|sqrt|exp|log|pow)' )
if [ -n "$fp" ]; then echo "libvd.a references floating-point helpers: $fp"; rc=1; fi
# float/double as words in code (comments skipped: lines starting with //, * or /*).
src=$(grep -rnE '\b(float|double)\b' "$dir" --include='*.c' --include='*.h' | grep -vE '^[^:]+:[0-9]+:\s*(//|\*|/\*)')
if [ -n "$src" ]; then echo "lib/ uses float/double:"; echo "$src"; rc=1; fi
if [ $rc -eq 0 ]; then echo "lib rules: no heap, no floating point: OK"; fi
exit $rc
