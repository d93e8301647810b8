/*
 * cost_util.h - what a function costs on the emulated board, for the tests
 * that print it (tests/firmware/CMakeLists.txt AFM_FW_COST_MODULES run under
 * QEMU with -icount shift=0: one instruction is one virtual nanosecond).
 * The board's CMSDK timer 0 counts that clock at 25 MHz, one tick per
 * COST_INSTR_PER_TICK instructions, as board/afm_board.c reads it
 * (docs/pil.md). On the host cost_ticks returns 0 and nothing is printed.
 */
#ifndef COST_UTIL_H
#define COST_UTIL_H

#include <stdint.h>
#include <stdio.h>

#define COST_INSTR_PER_TICK 40u

#if defined(__arm__)
#define COST_TIMER0_CTRL (*(volatile uint32_t *)0x40000000u)
#define COST_TIMER0_VALUE (*(volatile uint32_t *)0x40000004u)
#define COST_TIMER0_RELOAD (*(volatile uint32_t *)0x40000008u)
static inline void cost_start_timer(void)
{
    COST_TIMER0_RELOAD = 0xFFFFFFFFu;
    COST_TIMER0_VALUE = 0xFFFFFFFFu;
    COST_TIMER0_CTRL = 1u;   /* enable, no interrupt */
}
/* The timer counts down: ticks since a reading t are t - cost_ticks(). */
static inline uint32_t cost_ticks(void) { return COST_TIMER0_VALUE; }
#define COST_ON_BOARD 1
#else
static inline void cost_start_timer(void) {}
static inline uint32_t cost_ticks(void) { return 0u; }
#define COST_ON_BOARD 0
#endif

/* Instructions a call from ticks over calls (resolution 40 / calls). */
static inline void cost_print(const char *what, uint32_t ticks, uint32_t calls)
{
    if (COST_ON_BOARD && calls > 0u) {
        printf("cost on the board: %s: %lu instructions a call (%lu calls, %lu ticks of 40)\n", what,
               (unsigned long)((uint64_t)ticks * COST_INSTR_PER_TICK / calls), (unsigned long)calls,
               (unsigned long)ticks);
    }
}

#endif /* COST_UTIL_H */
