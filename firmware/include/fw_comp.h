/*
 * fw_comp.h - position control and bending compensation (physics.md
 * section 4).
 *
 *   offset_C = [+C_n S_n, C_l S_l, 0]              (pm; C in pm/V, S in V)
 *   p_tip    = p_piezo + R(alpha) offset_C          (apex estimate, frame A)
 *   p_cmd    = centre + kappa * r_half * p_joy      (joystick -> frame A)
 *   piezo    = p_cmd - R(alpha) offset_C            (puts the APEX at p_cmd)
 *
 * Sign of the bending term: the tip hangs h below the lever's free end and
 * turns with it. S_n > 0 is the lever bent up (F_z = +k_n K_n S_n, eq. 1c);
 * its end then tilts nose-up and swings the apex towards the free end, +x_C,
 * by h times the slope, i.e. +C_n S_n (C_n = 3 h K_n / (2 l)). The same
 * holds for the moment of F_x (eq. 1c: it adds to S_n and displaces the apex
 * along +F_x, as a spring must). physics.md section 4 prints -C_n S_n, which
 * contradicts its section 1 with x from base to tip; the paper (II-E) also
 * finds the lines shifting along +x_C with deeper pushes.
 *
 * The joystick is 1.15 in [-1, 1); full deflection with kappa = 1 reaches
 * centre +- r_half (r_half = r_scan / 2), i.e. kappa r_scan p_joy with p_joy
 * in [-1/2, 1/2).
 */
#ifndef FW_COMP_H
#define FW_COMP_H

#include "fw_types.h"
#include "fw_math.h"

/* The fast path's bound on C_n, C_l (pm/V): with |S| <= 20 V (the fast
 * path's signals, fw_acq_step_fast_q23) every offset stays below 2^26 pm:
 * |C S| <= 2^21 20 2^23 < 2^48.4 in 64 bits, >> 23 rounded, |o| < 2^25.4
 * pm, rotated |R o| < 2^26, so fw_comp_apex_pm's clamps on the offset
 * cannot act and only the apex itself can leave int32 (fw_board.c's fast
 * path forms it so and hands such a sample to the checked path). */
#define FW_COMP_FAST_C_MAX_PM_PER_V ((int32_t)1 << 21)

typedef struct {
    int32_t cn_pm_per_v;     /* C_n, pm/V */
    int32_t cl_pm_per_v;     /* C_l, pm/V */
    q30_t cos_a;             /* cos alpha, 2.30 */
    q30_t sin_a;             /* sin alpha, 2.30 */
    int32_t center_pm[2];    /* frame A */
    int32_t half_range_pm;   /* r_scan / 2 */
    q16_t kappa;             /* 16.16 */
    bool fast;               /* C_n, C_l <= FW_COMP_FAST_C_MAX_PM_PER_V: fw_board_step's fast
                                path may form the apex without clamps (fw_board.c) */
} fw_comp_t;

/* Validates C_n, C_l >= 0, half range >= 0, kappa >= 0. */
fw_status_t fw_comp_init(fw_comp_t *c, int32_t cn_pm_per_v, int32_t cl_pm_per_v,
                         fw_bam_t alpha, const int32_t center_pm[2],
                         int32_t half_range_pm, q16_t kappa);

/* Bending offset in frame A (pm) for S_n, S_l in 9.23 V. Inline (per
 * sample).
 * Scaling and overflow: C * S in 64 bits (< 2^62) >> 23 rounded (half up)
 * and saturated to int32 (*sat); rotated by R(alpha) with 64-bit products
 * (fw_math_rotate_unit_i32: cos_a, sin_a come from fw_math_sincos_q30, so
 * they lie in [-1, 1]), rounded, saturated (*sat). */
static inline void fw_comp_offset_pm(const fw_comp_t *c, q23_t sn_v, q23_t sl_v,
                                     int32_t off_a_pm[3], bool *sat)
{
    int32_t ox = fw_math_sat_i32(
        fw_math_rshift_round_i64((int64_t)c->cn_pm_per_v * sn_v, FW_Q23_FRAC), sat);
    int32_t oy = fw_math_sat_i32(
        fw_math_rshift_round_i64((int64_t)c->cl_pm_per_v * sl_v, FW_Q23_FRAC), sat);
    fw_math_rotate_unit_i32(ox, oy, c->cos_a, c->sin_a, &off_a_pm[0], &off_a_pm[1], sat);
    off_a_pm[2] = 0;
}

/* Apex estimate: piezo + offset (xyz, pm), saturated (*sat); z is the
 * piezo's (the offset has no z). Inline (per sample). */
static inline void fw_comp_apex_pm(const fw_comp_t *c, const int32_t piezo_pm[3], q23_t sn_v,
                                   q23_t sl_v, int32_t apex_pm[3], bool *sat)
{
    int32_t off[3];
    fw_comp_offset_pm(c, sn_v, sl_v, off, sat);
    apex_pm[0] = fw_math_sat_i32((int64_t)piezo_pm[0] + off[0], sat);
    apex_pm[1] = fw_math_sat_i32((int64_t)piezo_pm[1] + off[1], sat);
    apex_pm[2] = piezo_pm[2];
}

/* Joystick (1.15) to the set point in frame A (pm).
 * Scaling and overflow: half_range * kappa (16.16) * joy (1.15) in 64 bits,
 * >> 31 rounded, plus centre, saturated (*sat). */
void fw_comp_target_pm(const fw_comp_t *c, const q15_t joy[2], int32_t target_pm[2], bool *sat);

/* Piezo xy set point that puts the apex at the joystick's target. */
void fw_comp_piezo_cmd_pm(const fw_comp_t *c, const q15_t joy[2], q23_t sn_v, q23_t sl_v,
                          int32_t piezo_pm[2], bool *sat);

#endif /* FW_COMP_H */
