/*
 * startup.c - vector table and reset handler for the Cortex-M4 images: the
 * board (afm_board.elf) and the firmware's unit tests on the cross build
 * (mps2-an386 under QEMU, newlib + rdimon semihosting; the linker script is
 * mps2_an386.ld beside it). Not part of the firmware library.
 *
 * Reset_Handler copies .data from flash, enables the FPU (CP10/CP11 full
 * access) when built hard-float, and jumps to newlib's _start, which zeroes
 * .bss, sets up semihosting and calls main; main's return value becomes
 * QEMU's exit status. Faults report over semihosting and exit with 1.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

extern uint32_t __etext;
extern uint32_t __data_start__;
extern uint32_t __data_end__;
extern uint32_t __stack_top__;
extern void _start(void);

void Reset_Handler(void);
void Fault_Handler(void);
void Default_Handler(void);

/* Coprocessor access control register; CP10 and CP11 full access. */
#define SCB_CPACR (*(volatile uint32_t *)0xE000ED88u)
#define CPACR_CP10_CP11_FULL (0xFu << 20)
#define VECTOR_COUNT 48

void Reset_Handler(void)
{
    uint32_t *src = &__etext;
    uint32_t *dst = &__data_start__;
    while (dst < &__data_end__) {
        *dst++ = *src++;
    }
#if defined(__ARM_FP)
    SCB_CPACR |= CPACR_CP10_CP11_FULL;
    __asm volatile("dsb\n\tisb" ::: "memory");
#endif
    _start();
    for (;;) {
    }
}

void Fault_Handler(void)
{
    fputs("FAULT: HardFault/MemManage/BusFault/UsageFault\n", stderr);
    exit(1);
}

void Default_Handler(void)
{
    fputs("FAULT: unexpected interrupt\n", stderr);
    exit(1);
}

typedef void (*vector_t)(void);

__attribute__((section(".vectors"), used))
static const vector_t vectors[VECTOR_COUNT] = {
    (vector_t)&__stack_top__,
    Reset_Handler,
    Default_Handler,   /* NMI */
    Fault_Handler,     /* HardFault */
    Fault_Handler,     /* MemManage */
    Fault_Handler,     /* BusFault */
    Fault_Handler,     /* UsageFault */
    0, 0, 0, 0,
    Default_Handler,   /* SVC */
    Default_Handler,   /* DebugMon */
    0,
    Default_Handler,   /* PendSV */
    Default_Handler,   /* SysTick */
    Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler,
};
