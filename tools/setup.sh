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
# arm toolchains + qemu-user: cross builds and ARM test runs.
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends \
  cmake ninja-build gcc clang libclang-rt-14-dev pkg-config libv4l-dev libstb-dev valgrind binutils \
  gcc-arm-none-eabi libnewlib-arm-none-eabi gcc-arm-linux-gnueabihf gcc-aarch64-linux-gnu qemu-user \
  python3 python3-pip >/dev/null
# Python tools (tools/pyproject.toml lists them): numpy, scikit-learn, scikit-image,
# opencv-python-headless (oracle + benchmark peer), matplotlib (figures), tqdm, pytest.
PIP="python3 -m pip"
$PIP install -q --upgrade pip >/dev/null 2>&1 || true
$PIP install -q -e "$(dirname "$0")"
