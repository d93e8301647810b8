/*
 * bench_q15.h - a 16-bit path of the per-sample chain (acquisition ->
 * compensation -> theta -> force -> rotation), the firmware bench's
 * comparison point for what accuracy costs. Not firmware: it lives in the
 * bench and nothing else uses it.
 *
 * "16-bit" means: every signal, gain, coefficient and direction is an
 * int16 (1.15 or an int16 mantissa with a fixed shift), every multiply is
 * 16 x 16 -> 32, divisions are 32 / 16, sums and shifts are 32-bit (a 16-bit
 * DSP's accumulator). Positions and forces that need more than 16 bits
 * (scanner pm, pN) are int32 and are only added, shifted, or multiplied by
 * a 1.15 value with two 16 x 16 products (bq15 "split multiply").
 *
 * Formats
 *   S_n, S_l     1.15 of 10 V: the 16-bit ADC code itself (LSB 305 uV)
 *   gains        value = S * mant >> (15 - k), mant int16, k fixed per gain
 *   offset       int16 in units of 2^k_off pm (8 pm for the paper's lever)
 *   cos/sin a    1.15 (cos 0 = 32767)
 *   direction    (cx, cy): the window displacement in frame C, normalised
 *                into [2^13, 2^14) by shifts, not a unit vector
 *   cot theta    4.12, |cot| <= 8 where it is used
 *   mu, 2h/l     1.15; fallback denominator 2.14
 *
 * Simplifications against fw_board_step (stated in the bench's table):
 *   - |sin theta| and cos theta are only formed where the fallback needs them
 *     (|sin| < 1/4), from t = tan theta by the series
 *     cos = 1 - t^2/2 + 3t^4/8, sin = t cos (error < 2e-5 for |t| <= 0.26);
 *     elsewhere the zone tests use squares and F_x = F_y cx / cy.
 *   - the friction fallback saturates at |mu c (N + F_adh)| = 131 nN.
 *   - no ADC filter, no virtual S_n, no flags or counters.
 */
#ifndef BENCH_Q15_H
#define BENCH_Q15_H

#include "fw_board.h"

typedef struct {
    int16_t n_mant;        /* k_n K_n 10 V / 2^n_k, pN */
    int16_t n_k;
    int16_t lat_mant;      /* k_theta K_l / h 10 V / 2^lat_k, pN */
    int16_t lat_k;
    int16_t cn_mant;       /* C_n 10 V / 2^off_k, pm */
    int16_t cl_mant;       /* C_l 10 V / 2^off_k, pm */
    int16_t off_k;
    int16_t cos_a;         /* 1.15 */
    int16_t sin_a;
    int16_t two_h_over_l;  /* 1.15 */
    int16_t mu;            /* 1.15 */
    int32_t adhesion_pn;
    int32_t min_disp2_pm2; /* (min displacement)^2, < 2^28 */
    int32_t x_pm[FW_THETA_WINDOW];
    int32_t y_pm[FW_THETA_WINDOW];
    int32_t pos;
    int32_t fill;
    int16_t cx;            /* latest direction, frame C, normalised */
    int16_t cy;
    int16_t known;
} bench_q15_t;

/* From the firmware's own configuration (integer arithmetic only). */
void bench_q15_init(bench_q15_t *p, const fw_board_config_t *cfg);
void bench_q15_reset(bench_q15_t *p);
void bench_q15_step(bench_q15_t *p, const fw_sample_in_t *in, int32_t force_a_pn[3]);

#endif /* BENCH_Q15_H */
