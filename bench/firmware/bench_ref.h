/*
 * bench_ref.h - double-precision reference of the firmware's per-sample
 * chain (fw_board.h steps 1, 3, 4, 5), for the firmware bench only.
 *
 * Same conventions as the firmware: alpha = scan angle - 270 deg, R(alpha)
 * takes frame C into frame A; apex = piezo + R(alpha) [+C_n S_n, C_l S_l]
 * (fw_comp.h); theta from the apex displacement over the last
 * FW_THETA_WINDOW samples rotated by R(-alpha), held below the minimum
 * displacement, 90 deg before any motion; force of the sample on the tip by
 * eq. 1a-1c with the friction fallback and blend of fw_force.h, rotated into
 * frame A (eq. 3), pN.
 *
 * Acquisition: with adc_bits != 0 the input is quantised like the card's
 * ADC (round half away from zero, clamped to the code range) and converted
 * to volts; with adc_bits == 0 the analog input is used as is (volts =
 * microvolts / 1e6). The ADC moving-average filter is not modelled (the
 * bench runs the firmware with filter_log2 = 0); neither is the virtual S_n
 * (the bench's inputs stay inside +-10 V).
 */
#ifndef BENCH_REF_H
#define BENCH_REF_H

#include "fw_board.h"

typedef struct {
    int adc_bits;           /* 0: analog input, else 12/14/16 */
    double normal_gain_pn_per_v;     /* k_n K_n */
    double lateral_gain_pn_per_v;    /* k_theta K_l / h */
    double two_h_over_l;
    double mu;
    double adhesion_pn;
    double disp_n_pm_per_v;
    double disp_l_pm_per_v;
    double cos_a;
    double sin_a;
    double min_disp_pm;
    double x_pm[FW_THETA_WINDOW];
    double y_pm[FW_THETA_WINDOW];
    int pos;
    int fill;
    double cos_theta;
    double sin_theta;
} bench_ref_t;

void bench_ref_init(bench_ref_t *r, const fw_board_config_t *cfg, int adc_bits);
void bench_ref_reset(bench_ref_t *r);
void bench_ref_step(bench_ref_t *r, const fw_sample_in_t *in, double force_a_pn[3]);

#endif /* BENCH_REF_H */
