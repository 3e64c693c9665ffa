// SPDX-License-Identifier: MIT
// Arm semihosting (the debugger's or emulator's console and exit), the only
// "I/O" of the firmware example: no UART driver, no vendor HAL.
#ifndef VD_FW_SEMIHOST_H
#define VD_FW_SEMIHOST_H

#include <stddef.h>
#include <stdint.h>

// Writes a NUL-terminated string to the host console (SYS_WRITE0).
void sh_puts(const char *s);
// Writes an unsigned decimal number.
void sh_putu(uint32_t v);
// v in decimal, written at the end of buf (11 bytes); returns where the digits start.
const char *sh_utoa(uint32_t v, char buf[11]);
// Ends the program with `status` as the emulator's exit code (SYS_EXIT_EXTENDED).
void sh_exit(int status) __attribute__((noreturn));

#endif
