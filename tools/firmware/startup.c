// SPDX-License-Identifier: MIT
// Reset and exception handling of the firmware example (Armv7-M: Cortex-M4/M7).
// Reset: enable the FPU, copy .data from flash, zero .bss, paint the stack
// (for the high-water mark), start SysTick (the clock of per-stage timing),
// then main(). Every fault prints its name over semihosting and exits with
// status 3, so a test sees a fault as a fault rather than a hang.
#include <stdint.h>

#include "board.h"
#include "semihost.h"

int main(void);

// Linker script symbols (mps2.ld).
extern uint32_t __data_load[], __data_start[], __data_end[], __bss_start[], __bss_end[];
extern uint32_t __stack_limit[], __stack_top[];

#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)
#define SCB_ICSR (*(volatile uint32_t *)0xE000ED04u)
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)
#define SYST_RELOAD 0x00FFFFFFu
#define ICSR_PENDSTSET (1u << 26)

static volatile uint32_t systick_wraps;

void Reset_Handler(void) __attribute__((noreturn));
void SysTick_Handler(void);
static void fault(const char *what) __attribute__((noreturn));
static void NMI_Handler(void) { fault("NMI"); }
static void HardFault_Handler(void) { fault("HardFault"); }
static void MemManage_Handler(void) { fault("MemManage"); }
static void BusFault_Handler(void) { fault("BusFault"); }
static void UsageFault_Handler(void) { fault("UsageFault"); }
static void Other_Handler(void) { fault("unexpected exception"); }

// Cortex-M vector table: initial SP, then the handlers; the linker script
// puts it at the start of flash (VTOR resets to 0).
__attribute__((section(".vectors"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(uintptr_t)__stack_top, Reset_Handler, NMI_Handler, HardFault_Handler, MemManage_Handler,
    BusFault_Handler, UsageFault_Handler, 0, 0, 0, 0, Other_Handler, Other_Handler, 0, Other_Handler,
    SysTick_Handler,
};

static void fault(const char *what)
{
    sh_puts("vd_fw: fault: ");
    sh_puts(what);
    sh_puts("\n");
    sh_exit(3);
}

void Reset_Handler(void)
{
#if defined(__ARM_FP)
    // Full access to CP10/CP11 before any floating-point instruction (the
    // hard-float ABI may use FP registers anywhere).
    SCB_CPACR |= 0xFu << 20;
    __asm__ volatile("dsb\n isb" ::: "memory");
#endif
    for (uint32_t *s = __data_load, *d = __data_start; d < __data_end;) {
        *d++ = *s++;
    }
    for (uint32_t *d = __bss_start; d < __bss_end;) {
        *d++ = 0u;
    }
    // Paint the stack below this frame; fw_stack_used() finds the deepest word changed.
    uint32_t *sp;
    __asm__ volatile("mov %0, sp" : "=r"(sp));
    for (uint32_t *p = __stack_limit; p < sp - 16; p++) {
        *p = FW_STACK_PAINT;
    }
    SYST_RVR = SYST_RELOAD;
    SYST_CVR = 0u;
    SYST_CSR = 7u;  // processor clock, interrupt on wrap, enable
    sh_exit(main());
}

void SysTick_Handler(void)
{
    systick_wraps++;
}

uint64_t fw_ticks(void)
{
    for (;;) {
        uint32_t w = systick_wraps;
        uint32_t v = SYST_CVR;
        uint32_t pend = SCB_ICSR & ICSR_PENDSTSET;
        if (w != systick_wraps) {
            continue;  // the wrap interrupt ran in between: read again
        }
        uint64_t t = ((uint64_t)w << 24) + (SYST_RELOAD - v);
        // Wrapped but the interrupt not taken yet (interrupts masked or just
        // pending): the count restarted near the reload value.
        if (pend != 0u && v > SYST_RELOAD / 2u) {
            t += (uint64_t)SYST_RELOAD + 1u;
        }
        return t;
    }
}

uint32_t fw_stack_used(void)
{
    const uint32_t *p = __stack_limit;
    while (p < __stack_top && *p == FW_STACK_PAINT) {
        p++;
    }
    return (uint32_t)((uintptr_t)__stack_top - (uintptr_t)p);
}

uint32_t fw_stack_size(void)
{
    return (uint32_t)((uintptr_t)__stack_top - (uintptr_t)__stack_limit);
}
