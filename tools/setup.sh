#!/usr/bin/env bash
# SPDX-License-Identifier: MIT
# Installs everything vd's build, tools and tests need on a fresh Debian machine
# (run as root, or with sudo). Idempotent.
set -euo pipefail
SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO=sudo; fi
export DEBIAN_FRONTEND=noninteractive
# cmake/ninja/gcc: build; clang + libclang-rt-14-dev: clang build and libFuzzer;
# libv4l-dev: V4L2 port; libstb-dev: PNG/JPEG decode and PNG encode in host tools;
# valgrind: leak checks and instruction counts; pkg-config: consumer test;
# arm toolchains + qemu-user: cross builds and ARM test runs; qemu-system-arm: the bare-metal
# firmware example (tools/firmware) on emulated MPS2 Cortex-M7/M4 boards;
# chromium + fonts-dejavu-core: the test renders vd_fir_demo --report's page headless (text needs a font).
# GStreamer element vdfir (tools/gst, docs/gstreamer.md): libgstreamer1.0-dev and
# libgstreamer-plugins-base1.0-dev build it (gstreamer-1.0/-base/-video); its tests run real
# pipelines with gstreamer1.0-tools (gst-inspect), gstreamer1.0-plugins-base (videoconvert,
# videotestsrc, rawvideoparse, decodebin) and gstreamer1.0-plugins-good (multifilesrc, pngdec,
# pngenc, jpegdec; v4l2src for cameras).
# Every package is named explicitly: --no-install-recommends drops what a package only recommends
# (the cross compilers' C libraries libc6-dev-*-cross were lost that way once).
PKGS=(cmake ninja-build make gcc libc6-dev clang libclang-rt-14-dev llvm pkg-config libv4l-dev libstb-dev
  valgrind binutils
  gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib
  gcc-arm-linux-gnueabihf libc6-dev-armhf-cross binutils-arm-linux-gnueabihf
  gcc-aarch64-linux-gnu libc6-dev-arm64-cross binutils-aarch64-linux-gnu
  qemu-user qemu-system-arm python3 python3-pip python3-venv
  chromium fonts-dejavu-core
  libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev gstreamer1.0-tools gstreamer1.0-plugins-base
  gstreamer1.0-plugins-good)
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${PKGS[@]}" >/dev/null

# Each toolchain must compile AND link a trivial program; one clear line names the package otherwise.
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
printf 'int main(void){return 0;}\n' >"$tmp/t.c"
printf '#include <stdint.h>\n#include <stddef.h>\nint LLVMFuzzerTestOneInput(const uint8_t *d, size_t n){(void)d;(void)n;return 0;}\n' >"$tmp/f.c"
check() {  # name, package(s), command...
  local name=$1 pkg=$2; shift 2
  if ! "$@" >"$tmp/log" 2>&1; then
    echo "setup.sh: $name cannot compile and link a trivial program; install: $pkg" >&2
    sed 's/^/  /' "$tmp/log" | head -5 >&2
    exit 1
  fi
}
check "host gcc" "gcc libc6-dev" gcc "$tmp/t.c" -o "$tmp/a"
check "clang" "clang" clang "$tmp/t.c" -o "$tmp/b"
check "clang libFuzzer + ASan/UBSan" "libclang-rt-14-dev" clang -fsanitize=fuzzer,address,undefined "$tmp/f.c" -o "$tmp/c"
check "arm-none-eabi" "gcc-arm-none-eabi libnewlib-arm-none-eabi" \
  arm-none-eabi-gcc -mcpu=cortex-m7 -mthumb --specs=nosys.specs "$tmp/t.c" -o "$tmp/d"
check "armhf" "gcc-arm-linux-gnueabihf libc6-dev-armhf-cross" arm-linux-gnueabihf-gcc "$tmp/t.c" -o "$tmp/e"
check "aarch64" "gcc-aarch64-linux-gnu libc6-dev-arm64-cross" aarch64-linux-gnu-gcc "$tmp/t.c" -o "$tmp/g"
check "qemu-arm (armhf program)" "qemu-user" qemu-arm -L /usr/arm-linux-gnueabihf "$tmp/e"
check "qemu-aarch64 (aarch64 program)" "qemu-user" qemu-aarch64 -L /usr/aarch64-linux-gnu "$tmp/g"
check "qemu-system-arm (MPS2 AN500/AN386 boards)" "qemu-system-arm" \
  sh -c 'qemu-system-arm -M help | grep -q mps2-an500 && qemu-system-arm -M help | grep -q mps2-an386'
have() {  # name, package(s), command...: a library or plugin that must be present
  local name=$1 pkg=$2; shift 2
  if ! "$@" >"$tmp/log" 2>&1; then
    echo "setup.sh: $name not found; install: $pkg" >&2
    exit 1
  fi
}
have "GStreamer development files" "libgstreamer1.0-dev libgstreamer-plugins-base1.0-dev" \
  pkg-config --exists gstreamer-1.0 gstreamer-base-1.0 gstreamer-video-1.0
for el in videoconvert videoscale videotestsrc rawvideoparse decodebin; do
  have "GStreamer element $el" "gstreamer1.0-tools gstreamer1.0-plugins-base" gst-inspect-1.0 --exists "$el"
done
for el in multifilesrc pngdec pngenc jpegdec; do
  have "GStreamer element $el" "gstreamer1.0-tools gstreamer1.0-plugins-good" gst-inspect-1.0 --exists "$el"
done

# Python tools (tools/pyproject.toml lists them): numpy, scikit-learn, scikit-image,
# opencv-python-headless (oracle + benchmark peer), matplotlib (figures), tqdm, pillow, motmetrics (tracking metrics); extras fleet (Dask) and test (pytest);
# the "fleet" extra: dask[distributed] for vdtools.evaluation.fleet and its fault tests (tests/python/test_fleet.py).
# Debian's own python3 is "externally managed" (PEP 668): pip refuses to install into it
# unless told --break-system-packages. That installs into /usr/local as root, ~/.local
# otherwise (Debian's packages under /usr stay untouched), where the README's plain
# `python3` finds the tools; a venv would not be on that python3's path. A pyenv or venv
# Python has no marker and is used as before. pip itself is upgraded only there: Debian's
# pip is patched to use the system CA store, a PyPI pip would shadow it in /usr/local.
PIP_INSTALL=(python3 -m pip install -q)
if python3 -c 'import os, sys, sysconfig; sys.exit(not os.path.exists(os.path.join(sysconfig.get_path("stdlib"), "EXTERNALLY-MANAGED")))'; then
  PIP_INSTALL+=(--break-system-packages)   # an install option: it must follow "install"
else
  "${PIP_INSTALL[@]}" --upgrade pip >/dev/null 2>&1 || true
fi
# the "adapt" extra: PyTorch for vd-adapt, which the tests run end to end (tests/python/test_adapt.py; also
# test_cnn_qat.py and test_cnn_prune.py run with it). From PyPI: download.pytorch.org's CPU-only index is not
# reachable from our machines, and PyPI's Linux x86-64 torch wheel brings the CUDA libraries along (~3 GB to
# download, ~4 GB installed; about 2 minutes on our machines, measured 2026-11-28). The tools use the CPU only.
"${PIP_INSTALL[@]}" -e "$(dirname "$0")[fleet,test,adapt]"
