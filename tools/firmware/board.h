// SPDX-License-Identifier: MIT
// What the firmware example needs from its board (startup.c): a tick counter
// and the stack high-water mark.
#ifndef VD_FW_BOARD_H
#define VD_FW_BOARD_H

#include <stdint.h>

// Core clock of the MPS2 FPGA images (AN386, AN500), which SysTick counts.
#ifndef FW_CPU_HZ
#define FW_CPU_HZ 25000000u
#endif
#define FW_STACK_PAINT 0xA5A5A5A5u

// SysTick cycles (FW_CPU_HZ) since reset, 64-bit (extended by the wrap interrupt).
uint64_t fw_ticks(void);
// Deepest stack use since reset, bytes (words below it still hold the paint).
uint32_t fw_stack_used(void);
// Stack size reserved by the linker script, bytes.
uint32_t fw_stack_size(void);

#endif
