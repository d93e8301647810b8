/* trench_util.h - what the trench tests share (test_wire_trench.c,
 * test_wire_settle.c): the paper's rod and a tip on it, and a straight
 * trench as fw_litho records one. */
#ifndef TRENCH_UTIL_H
#define TRENCH_UTIL_H

#include "unity.h"
#include "fw_wire.h"
#include "fw_litho.h"

#define L_PM 1300000     /* the paper's 1.3 um x 100 nm silver rod */
#define D_PM 100000

/* A straight trench from (x0, y) to (x1, y) of one width, as fw_litho
 * records it: points every 20 nm, the first a stroke's start. */
static inline int32_t straight_trench(fw_trench_point_t *p, int32_t cap, int32_t x0, int32_t x1, int32_t y, int32_t width)
{
    int32_t n = 0, x;
    for (x = x0; x <= x1 && n < cap; x += 20000) {
        p[n].x_pm = x;
        p[n].y_pm = y;
        p[n].width_pm = width;
        p[n].depth_pm = width;   /* unused by the hold */
        p[n].flags = n == 0 ? FW_LITHO_STROKE_START : 0u;
        n++;
    }
    return n;
}

static inline void rod_and_tip(fw_wire_t *w, fw_wire_tip_t *tip)
{
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_init(w, 0, 0, 0u, L_PM, D_PM));
    TEST_ASSERT_EQUAL_INT(FW_OK, fw_wire_tip_init(tip, 10000, 20000, 20000, 300000, 0));
}

#endif
