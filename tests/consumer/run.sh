#!/bin/sh
# SPDX-License-Identifier: MIT
# usage: run.sh VD_BUILD_DIR CONSUMER_SRC CMAKE CC
# Installs vd from its build tree to a scratch prefix, then builds and runs the
# consumer with find_package(vd) and, separately, with pkg-config flags.
set -eu
build=$1; src=$2; cmake=$3; cc=$4
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$cmake" --install "$build" --prefix "$work/prefix" >/dev/null
"$cmake" -S "$src" -B "$work/build" -DCMAKE_PREFIX_PATH="$work/prefix" -DCMAKE_C_COMPILER="$cc" >/dev/null
"$cmake" --build "$work/build" >/dev/null
"$work/build/consumer"
if command -v pkg-config >/dev/null 2>&1; then
  flags=$(PKG_CONFIG_PATH="$work/prefix/lib/pkgconfig:$work/prefix/lib64/pkgconfig" pkg-config --cflags --libs vd)
  # shellcheck disable=SC2086
  "$cc" -std=c99 -o "$work/consumer_pc" "$src/main.c" $flags
  "$work/consumer_pc"
fi
