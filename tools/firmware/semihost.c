// SPDX-License-Identifier: MIT
// Semihosting calls: BKPT 0xAB with the operation in r0 and its argument in r1
// (Arm "Semihosting for AArch32 and AArch64", version 2). Under QEMU this
// needs -semihosting; on a board, an attached debugger.
#include "semihost.h"

#define SYS_WRITE0 0x04u
#define SYS_EXIT_EXTENDED 0x20u
#define ADP_STOPPED_APPLICATION_EXIT 0x20026u

static uint32_t sh_call(uint32_t op, const void *arg)
{
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void sh_puts(const char *s)
{
    (void)sh_call(SYS_WRITE0, s);
}

const char *sh_utoa(uint32_t v, char buf[11])
{
    unsigned i = 10u;
    buf[i] = '\0';
    do {
        buf[--i] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0u);
    return &buf[i];
}

void sh_putu(uint32_t v)
{
    char buf[11];
    sh_puts(sh_utoa(v, buf));
}

void sh_exit(int status)
{
    // Extended exit carries the status (plain SYS_EXIT only says "ok" or "not").
    const uint32_t block[2] = {ADP_STOPPED_APPLICATION_EXIT, (uint32_t)status};
    for (;;) {
        (void)sh_call(SYS_EXIT_EXTENDED, block);
    }
}
