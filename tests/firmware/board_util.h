/* board_util.h - what the board's tests share (test_board.c,
 * test_board_fast.c): the paper's board configuration they start from, and
 * two boards compared to the bit. */
#ifndef BOARD_UTIL_H
#define BOARD_UTIL_H

#include <stdio.h>
#include <string.h>
#include "unity.h"
#include "fw_board.h"
#include "fw_paper_probe.h"

/* The paper's lever (fw_paper_probe.h) at 270 deg, adhesion 5 nN, the
 * joystick's centre at (45, 45) um. */
static inline void paper_config(fw_board_config_t *c)
{
    fw_paper_board_config(c, 270000);
    c->adhesion_pn = 5000;
    c->scan_center_pm[0] = 45000000;
    c->scan_center_pm[1] = 45000000;
}

/* f and c, and their outputs of sample i, field by field: the fast and the
 * checked path, or a block and single steps, must agree to the bit. */
static inline void assert_boards_identical(const fw_board_t *f, const fw_board_t *c, const fw_sample_out_t *of,
                                    const fw_sample_out_t *oc, long i)
{
    int k;
    bool same = memcmp(of, oc, sizeof *of) == 0
                && f->sn_v == c->sn_v && f->sl_v == c->sl_v && f->z_pm == c->z_pm
                && f->sn_ref_v == c->sn_ref_v && f->z_ref_pm == c->z_ref_pm
                && f->have_ref == c->have_ref && f->ref_live == c->ref_live
                && f->stepped == c->stepped && f->fast_span_uv == c->fast_span_uv
                && f->sticky_flags == c->sticky_flags && f->sat_force_count == c->sat_force_count
                && f->acq_sn.last_v == c->acq_sn.last_v && f->acq_sl.last_v == c->acq_sl.last_v
                && f->acq_sn.sat_count == c->acq_sn.sat_count && f->acq_sl.sat_count == c->acq_sl.sat_count
                && f->acq_sn.sat_sticky == c->acq_sn.sat_sticky && f->acq_sl.sat_sticky == c->acq_sl.sat_sticky
                && f->theta.pos == c->theta.pos && f->theta.fill == c->theta.fill
                && f->theta.dir_x == c->theta.dir_x && f->theta.dir_y == c->theta.dir_y
                && f->theta.known == c->theta.known;
    for (k = 0; k < FW_THETA_WINDOW; k++) {
        same = same && f->theta.x_pm[k] == c->theta.x_pm[k] && f->theta.y_pm[k] == c->theta.y_pm[k];
    }
    if (!same) {
        printf("sample %ld: fast F = (%ld, %ld, %ld) flags 0x%lx, checked F = (%ld, %ld, %ld) flags 0x%lx\n", i,
               (long)of->force_pn[0], (long)of->force_pn[1], (long)of->force_pn[2], (unsigned long)of->flags,
               (long)oc->force_pn[0], (long)oc->force_pn[1], (long)oc->force_pn[2], (unsigned long)oc->flags);
        TEST_FAIL_MESSAGE("fast and checked paths differ");
    }
}

#endif
