/*
 * fw_paper_probe.h - the paper's lever (physics.md section 12) in the
 * firmware's units: the one reference configuration of the firmware's
 * tests, its benchmark, the lever calculator and the scene's defaults. The
 * card itself never reads it: a run's probe comes from its scene.
 */
#ifndef FW_PAPER_PROBE_H
#define FW_PAPER_PROBE_H

#include "fw_board.h"

#define FW_PAPER_KN_MN_PER_M 120                /* k_n = 0.12 N/m */
#define FW_PAPER_DEFLECTION_PM_PER_V 89000      /* K_n = 89 nm/V */
#define FW_PAPER_NORMAL_GAIN_PN_PER_V 10680     /* k_n K_n = 10.68 nN/V */
#define FW_PAPER_LATERAL_GAIN_PN_PER_V 37900    /* k_theta K_l / h from the friction loops: 37.9 nN/V */
#define FW_PAPER_TIP_HEIGHT_NM 17300            /* h */
#define FW_PAPER_LEVER_LENGTH_NM 100000         /* l */
#define FW_PAPER_DISP_PM_PER_V 23100            /* C_n from the inscribed lines: 23.1 nm/V */
#define FW_PAPER_MU_PPM 86500                   /* tip on glass, from the friction loops: 0.0865 */

/* The signal chain on the paper's lever at a scan angle (mdeg): 16-bit
 * ADC, C_n = C_l = 23.1 nm/V, mu 0.0865, no adhesion, the joystick's
 * centre at the origin with a 5 um field (half range 2.5 um), kappa 1. */
static inline void fw_paper_board_config(fw_board_config_t *c, int32_t scan_angle_mdeg)
{
    c->adc_bits = 16;
    c->normal_gain_pn_per_v = FW_PAPER_NORMAL_GAIN_PN_PER_V;
    c->lateral_gain_pn_per_v = FW_PAPER_LATERAL_GAIN_PN_PER_V;
    c->deflection_pm_per_v = FW_PAPER_DEFLECTION_PM_PER_V;
    c->tip_height_nm = FW_PAPER_TIP_HEIGHT_NM;
    c->lever_length_nm = FW_PAPER_LEVER_LENGTH_NM;
    c->disp_n_pm_per_v = FW_PAPER_DISP_PM_PER_V;
    c->disp_l_pm_per_v = FW_PAPER_DISP_PM_PER_V;
    c->scan_angle_mdeg = scan_angle_mdeg;
    c->mu_ppm = FW_PAPER_MU_PPM;
    c->adhesion_pn = 0;
    c->scan_center_pm[0] = 0;
    c->scan_center_pm[1] = 0;
    c->scan_half_range_pm = 2500000;
    c->kappa_q16 = FW_Q16_ONE;
    c->filter_log2 = 0;
    c->theta_min_disp_pm = 0;
}

#endif /* FW_PAPER_PROBE_H */
