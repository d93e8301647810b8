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
 * along +F_x, as a spring must). docs/physics.md section 4 gives the same
 * +C_n S_n (an earlier version of the notes printed -C_n S_n, which put the
 * apex estimate about 22 nm off); the paper (II-E) also finds the lines
 * shifting along +x_C with deeper pushes.
 *
 * The joystick is 1.15 in [-1, 1); full deflection with kappa = 1 reaches
 * centre +- r_half (r_half = r_scan / 2), i.e. kappa r_scan p_joy with p_joy
 * in [-1/2, 1/2).
 */
#ifndef FW_COMP_H
#define FW_COMP_H

#include "fw_types.h"
#include "fw_math.h"
#include "fw_rules.h"
#include "fw_acq.h"

/* The domain of C_n, C_l (pm/V): [0, 2^22] (4.2 um/V; the paper's lever
 * has 23.1 nm/V, and C_n = 3 h K_n / (2 l) stays below 2^21 for any lever
 * with h <= l and K_n <= 1 um/V). Larger values are refused by
 * fw_comp_init (FW_ERR_DOMAIN): they would let the offset leave int32. */
#define FW_COMP_C_MAX_PM_PER_V ((int32_t)1 << 22)

/* The bending offset in frame A is one linear map of the signals,
 *   offset_A = M [S_n, S_l],  M = R(alpha) diag(C_n, C_l),
 * kept in pm/V with FW_COMP_M_FRAC fraction bits (each entry rounded once
 * at init: 2^-9 pm/V, so 0.04 pm at 20 V and 0.7 pm at the virtual S_n's
 * 256 V), |m| <= 2^22 2^8 = 2^30. */
#define FW_COMP_M_FRAC 8

/* The fast path's bound on C_n, C_l (pm/V): with |S| <= 20 V (the fast
 * path's signals, fw_acq_take_code_q23) every offset stays below 2^26 pm:
 * |M S| <= 2^21.5 2^8 20 2^23 < 2^57 in 64 bits, >> 31 rounded, so only
 * the apex itself can leave int32 (fw_board.c's fast path forms it so and
 * hands such a sample to the checked path). */
#define FW_COMP_FAST_C_MAX_PM_PER_V ((int32_t)1 << 21)

typedef struct {
    q30_t cos_a;             /* cos alpha, 2.30 */
    q30_t sin_a;             /* sin alpha, 2.30 */
    int32_t m[2][2];         /* M = R(alpha) diag(C_n, C_l), pm/V, FW_COMP_M_FRAC fraction bits */
    int32_t center_pm[2];    /* frame A */
    int32_t half_range_pm;   /* r_scan / 2 */
    q16_t kappa;             /* 16.16 */
    bool fast;               /* C_n, C_l <= FW_COMP_FAST_C_MAX_PM_PER_V: fw_board_step's fast
                                path may form the apex without clamps (fw_board.c) */
} fw_comp_t;

/* The first rule broken: C_n, C_l < 0 (FW_RULE_DISP_NEGATIVE); above
 * FW_COMP_C_MAX_PM_PER_V (FW_RULE_DISP_RANGE: they would let the offset
 * leave int32); half range or kappa < 0 (FW_RULE_JOYSTICK_RANGE). C = 0
 * turns the compensation off on that axis. */
fw_rule_t fw_comp_check(int32_t disp_n_pm_per_v, int32_t disp_l_pm_per_v, int32_t half_range_pm, q16_t kappa);

/* Validates with fw_comp_check (its rule's status; FW_ERR_ARG for a NULL
 * pointer). Forms M: m = round(C cos alpha / 2^22), +-round(C sin alpha /
 * 2^22) (cos, sin alpha in 2.30; half up). */
fw_status_t fw_comp_init(fw_comp_t *c, int32_t disp_n_pm_per_v, int32_t disp_l_pm_per_v,
                         fw_bam_t alpha, const int32_t center_pm[2],
                         int32_t half_range_pm, q16_t kappa);

/* One component of the bending offset in frame A (pm): round((m_0 S_n +
 * m_1 S_l) / 2^(23 + FW_COMP_M_FRAC)), half up, for a row (m_0, m_1) of M
 * and S_n, S_l in 9.23 V. Inline (per sample).
 * Scaling and overflow: |m| <= 2^30 and |S| <= 2^31 (any 9.23 value), so
 * each product < 2^61 and the sum < 2^62 in 64 bits; the row of
 * R(alpha) diag(C_n, C_l) has |m_0| + |m_1| <= 2^(30.5), so the result
 * lies within +-2^30.5 pm: it cannot leave int32, and no clamp exists. */
static inline int32_t fw_comp_offset_row_pm(const int32_t m_row[2], q23_t sn_v, q23_t sl_v)
{
    return (int32_t)fw_math_rshift_round_i64((int64_t)m_row[0] * sn_v + (int64_t)m_row[1] * sl_v,
                                             FW_Q23_FRAC + FW_COMP_M_FRAC);
}

/* Bending offset in frame A (pm) for S_n, S_l in 9.23 V, z = 0:
 * fw_comp_offset_row_pm for both rows of M (never saturates: see there).
 * Inline (per sample). */
static inline void fw_comp_offset_pm(const fw_comp_t *c, q23_t sn_v, q23_t sl_v, int32_t off_a_pm[3])
{
    off_a_pm[0] = fw_comp_offset_row_pm(c->m[0], sn_v, sl_v);
    off_a_pm[1] = fw_comp_offset_row_pm(c->m[1], sn_v, sl_v);
    off_a_pm[2] = 0;
}

/* Apex estimate: piezo + offset (xyz, pm); x, y saturated to int32 (*sat:
 * only a piezo position within 2^30.5 pm of the int32 ends can get there);
 * z is the piezo's (the offset has no z). Inline (per sample). */
static inline void fw_comp_apex_pm(const fw_comp_t *c, const int32_t piezo_pm[3], q23_t sn_v,
                                   q23_t sl_v, int32_t apex_pm[3], bool *sat)
{
    int32_t off[3];
    fw_comp_offset_pm(c, sn_v, sl_v, off);
    apex_pm[0] = fw_math_sat_i32((int64_t)piezo_pm[0] + off[0], sat);
    apex_pm[1] = fw_math_sat_i32((int64_t)piezo_pm[1] + off[1], sat);
    apex_pm[2] = piezo_pm[2];
}

/* The bending offset straight from the ADC codes, for the card's fast path
 * (acquisition without filter): row i of M S with S = code lsb - baseline,
 *   off_i = floor((code_n mul[i][0] + code_l mul[i][1] + add[i]) / 2^31),
 * mul[i][j] = m_ij lsb_j, add[i] = 2^30 - m_i0 baseline_n - m_i1 baseline_l:
 * fw_comp_offset_row_pm's value on the baseline-corrected signals, exactly
 * (fw_acq_gain's algebra). Formed by fw_comp_code_gains for the baselines
 * of the moment; the caller forms it again when a baseline changes. */
typedef struct {
    int64_t mul[2][2];
    int64_t add[2];
} fw_comp_code_gains_t;

/* Scaling and overflow: |m| <= 2^30 and |lsb|, |baseline| <= 10 V in 9.23,
 * so |mul|, |m baseline| < 2^56.4 (fw_acq_gain). */
void fw_comp_code_gains(const fw_comp_t *c, const fw_acq_t *acq_n, const fw_acq_t *acq_l,
                        fw_comp_code_gains_t *g);

/* The offset in frame A (pm) from two codes, as fw_comp_code_gains
 * documents; aligned: M is diagonal (alpha = 0 exactly), the cross terms
 * are skipped. Scaling and overflow: a code within the ADC's range has
 * |code mul| = |code lsb| |m| <= 10 V 2^23 2^30 < 2^56.4, so the sum stays
 * < 2^58.5 in 64 bits; the offset itself is M S (fw_comp_offset_row_pm's
 * bound). Inline (per sample). */
static FW_ALWAYS_INLINE void fw_comp_offset_codes_pm(const fw_comp_code_gains_t *g, int32_t code_n,
                                                     int32_t code_l, bool aligned, int64_t off_pm[2])
{
    if (aligned) {
        off_pm[0] = fw_math_asr_i64(code_n * g->mul[0][0] + g->add[0], FW_Q23_FRAC + FW_COMP_M_FRAC);
        off_pm[1] = fw_math_asr_i64(code_l * g->mul[1][1] + g->add[1], FW_Q23_FRAC + FW_COMP_M_FRAC);
    } else {
        off_pm[0] = fw_math_asr_i64(code_n * g->mul[0][0] + code_l * g->mul[0][1] + g->add[0],
                                    FW_Q23_FRAC + FW_COMP_M_FRAC);
        off_pm[1] = fw_math_asr_i64(code_n * g->mul[1][0] + code_l * g->mul[1][1] + g->add[1],
                                    FW_Q23_FRAC + FW_COMP_M_FRAC);
    }
}

/* Joystick (1.15) to the set point in frame A (pm).
 * Scaling and overflow: half_range * kappa (16.16) * joy (1.15) in 64 bits,
 * >> 31 rounded, plus centre, saturated (*sat). */
void fw_comp_target_pm(const fw_comp_t *c, const q15_t joy[2], int32_t target_pm[2], bool *sat);

/* Piezo xy set point that puts the apex at the joystick's target. */
void fw_comp_piezo_cmd_pm(const fw_comp_t *c, const q15_t joy[2], q23_t sn_v, q23_t sl_v,
                          int32_t piezo_pm[2], bool *sat);

#endif /* FW_COMP_H */
