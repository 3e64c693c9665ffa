#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Cross builds of vd (issue: embedded readiness): the library for Cortex-M7/M4/M0+
# (-Werror, MinSizeRel; M7/M4 with the CMSIS-NN back end where ../shared/vendor/cmsis-nn is; the names
# each libvd.a defines checked by tests/check_lib_symbols.py), the unit
# tests for armhf and aarch64 run under qemu-user, the CNN's (and the resampler's) unit tests on Cortex-M7 code with the
# CMSIS-NN back end under qemu-user. Then the embedded budget checks
# (tools/vdtools/generators/embedded_report.py --check).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
for t in cortex-m7 cortex-m4 cortex-m0plus; do
  echo "== $t: libvd.a"
  cmake -S . -B "build-$t" -G Ninja -DCMAKE_TOOLCHAIN_FILE="tools/toolchains/$t.cmake" -DCMAKE_BUILD_TYPE=MinSizeRel >/dev/null
  cmake --build "build-$t" -j "$jobs" >/dev/null
  # Only the public functions: vd__ internals and CMSIS-NN are local in the prelinked archive (docs/architecture.md, "Names").
  python3 tests/check_lib_symbols.py lib/include/vd "$(sed -n 's/^CMAKE_NM:[A-Z]*=//p' "build-$t/CMakeCache.txt")" \
    "build-$t/libvd.a"
done
for t in armhf aarch64; do
  echo "== $t: unit tests under qemu-user"
  cmake -S . -B "build-$t" -G Ninja -DCMAKE_TOOLCHAIN_FILE="tools/toolchains/$t.cmake" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DVD_BUILD_TOOLS=OFF -DVD_BUILD_PORT=OFF >/dev/null
  cmake --build "build-$t" -j "$jobs" >/dev/null
  ctest --test-dir "build-$t" --output-on-failure -j "$jobs" -L unit
done
# The CNN's unit tests on Cortex-M7 code with the CMSIS-NN back end (../shared/vendor/cmsis-nn): compiled
# -mcpu=cortex-m7 as for the firmware, run under qemu-user (tools/toolchains/cortex-m7-qemu.cmake says how).
echo "== cortex-m7 code, CMSIS-NN back end: CNN unit tests under qemu-user"
cmake -S . -B build-cortex-m7-qemu -G Ninja -DCMAKE_TOOLCHAIN_FILE=tools/toolchains/cortex-m7-qemu.cmake \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVD_BUILD_TOOLS=OFF -DVD_BUILD_PORT=OFF -DVD_CNN_CMSIS=ON >/dev/null
cmake --build build-cortex-m7-qemu -j "$jobs" --target test_cnn test_detector_cnn test_boost test_resample >/dev/null
ctest --test-dir build-cortex-m7-qemu --output-on-failure -j "$jobs" -R '^test_(cnn|detector_cnn|boost|resample)$'
if [ -f tools/vdtools/generators/embedded_report.py ]; then
  PYTHONPATH=tools${PYTHONPATH:+:$PYTHONPATH} python3 -m vdtools.generators.embedded_report --check
fi
