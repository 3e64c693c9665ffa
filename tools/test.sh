#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Runs every test of vd: the gcc build's CTest suite (unit, rules, consumer),
# the Python oracle and parity tests against the shared build, the clang build
# (-Werror), and the whole CTest suite again under ASan + UBSan.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)

echo "== gcc build + unit tests"
# A cache made by another compiler (the preset leaves cc) makes CMake drop it and re-run without the
# other -D values, so the build type was lost and the first run built unoptimised: start afresh instead.
if [ -f build/CMakeCache.txt ] && ! grep -q "^CMAKE_C_COMPILER:[A-Z]*=\(.*/\)\?gcc$" build/CMakeCache.txt; then
  rm -rf build/CMakeCache.txt build/CMakeFiles
fi
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=gcc >/dev/null
cmake --build build -j "$jobs"
ctest --test-dir build --output-on-failure -j "$jobs"

echo "== clang build (-Werror)"
cmake -S . -B build-clang -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_C_COMPILER=clang -DVD_BUILD_TESTS=ON >/dev/null
cmake --build build-clang -j "$jobs"

echo "== GCC static analyzer (-fanalyzer) on lib/ and the host code, the gcc build's flags (-Werror)"
tests/analyzer.sh build

echo "== ASan + UBSan build + unit tests"
cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_COMPILER=clang -DVD_SANITIZE=ON >/dev/null
cmake --build build-asan -j "$jobs"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir build-asan --output-on-failure -j "$jobs" -LE install

echo "== libFuzzer + ASan/UBSan, ${FUZZ_SECONDS:-20} s per fuzzer (11 fuzzers; CI stays under 30 min)"; FUZZ_SECONDS="${FUZZ_SECONDS:-20}" tests/fuzz/run.sh

echo "== cross builds (Cortex-M7/M4/M0+) and ARM unit tests under qemu-user"
tests/cross_run.sh

echo "== Python oracle, parity and end-to-end tests (shared build: build/libvd.so)"
# PYTHONPATH: the tests also run from a worktree without the editable install of tools/
PYTHONPATH="$PWD/tools${PYTHONPATH:+:$PYTHONPATH}" VD_LIB="$PWD/build/libvd.so" VD_BUILD_DIR="$PWD/build" python3 -m pytest -q tests/python
