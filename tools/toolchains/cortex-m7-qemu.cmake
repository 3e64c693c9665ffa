# SPDX-License-Identifier: MIT
# Cortex-M7 code in Linux programs, so the unit tests run under qemu-user (tests/cross_run.sh): the library and
# the tests compile as for the Cortex-M7 (-mcpu=cortex-m7 -mthumb: Thumb-2, the DSP extension, so the CMSIS-NN
# back end's SMLAD kernels; FPv5, hard-float ABI), link against the armhf C library (Armv7-A Thumb-2 and DSP are
# a superset of the M7's instructions, same ABI) with the linker's M/A profile check off, and run on qemu-arm's
# A-profile "max" CPU (qemu-arm 7.2 cannot start a Linux program on an M-profile CPU). Not for firmware:
# tools/toolchains/cortex-m7.cmake is the bare-metal one.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR arm)
set(CMAKE_C_COMPILER arm-linux-gnueabihf-gcc)
set(CMAKE_NM arm-linux-gnueabihf-nm)
set(CMAKE_C_FLAGS_INIT "-mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-Wl,--no-warn-mismatch")
set(CMAKE_CROSSCOMPILING_EMULATOR qemu-arm;-cpu;max;-L;/usr/arm-linux-gnueabihf)
set(CMAKE_FIND_ROOT_PATH /usr/arm-linux-gnueabihf)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
