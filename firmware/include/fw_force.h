/*
 * fw_force.h - force on the tip from the photodiode signals (physics.md
 * section 1, eq. 1a-1c and 3).
 *
 * The force is the force exerted BY THE SAMPLE ON THE TIP, z up. Friction
 * on a moving tip opposes its motion (cos theta, sin theta) in frame C, so
 * for friction F_x / F_y = cos theta / sin theta.
 *
 *   F_y = (k_theta K_l / h) S_l                               (1a)
 *   F_x = F_y cot theta                                       (1b)
 *   F_z = k_n K_n S_n - (2 h / l) F_x                         (1c)
 *
 * Near sin theta = 0, (1b) is 0/0. Fallback: the friction estimate
 *   F_x,fb = -mu (F_z + F_adh) cos theta
 * solved together with (1c):
 *   F_x,fb = -mu cos theta (k_n K_n S_n + F_adh) / (1 - mu cos theta 2h/l)
 * (init requires mu 2h/l <= 1/2, so the denominator is in [1/2, 3/2]).
 * Blend, continuous in theta:
 *   w = clamp((|sin theta| - S_LO) / (S_HI - S_LO), 0, 1)
 *   F_x = w F_x,cot + (1 - w) F_x,fb
 * with S_LO = 1/8 (7.2 deg) and S_HI = 1/4 (14.5 deg). For
 * |sin theta| < S_HI the flag FW_FLAG_FX_UNOBSERVABLE is set. F_x,cot is
 * only evaluated for |sin theta| >= S_LO, where |cot theta| <= 8, so no
 * division by a vanishing sin theta ever happens.
 *
 * One solver. The direction of motion is given as a vector (dir_x, dir_y)
 * of any length in frame C, theta = atan2(dir_y, dir_x), as fw_theta
 * leaves it; the unit vector is never formed where it is not needed:
 * F_x,cot = F_y x / y, the zones are tested on squares, and cos theta (and
 * |sin theta| for the blend) are formed only below S_HI (fw_force_fx_pn,
 * the zones; fw_force_blend_pn, the only blend). Two wrappers take the
 * zones' result to the three outputs:
 *   fw_force_solve_fit_pn   saturates every step; any signals and gains
 *                           (fw_force_solve_pn: the same with argument
 *                           checks and any vector length);
 *   fw_force_solve_fast_pn  the card's fast path: takes the terms N, F_y
 *                           as formed from the ADC codes and omits the
 *                           clamps, which its bounds make impossible.
 * They differ only in those clamps; tests/firmware/test_force.c and
 * test_board_fast.c prove them equal over their sweeps.
 */
#ifndef FW_FORCE_H
#define FW_FORCE_H

#include "fw_types.h"
#include "fw_math.h"
#include "fw_rules.h"

#define FW_FORCE_XFRAC 8                    /* extra fraction bits of F_y, N, F_z */
#define FW_FORCE_DIR_MAX ((int32_t)1 << 15) /* |x|, |y| bound of a direction vector */
/* The fast path's bounds (fw_force_solve_fast_pn): with |S| <= 20 V no
 * force term can leave int32. */
#define FW_FORCE_FAST_GAIN_MAX_PN_PER_V ((int32_t)1 << 18)  /* k_n K_n and k_theta K_l / h */
#define FW_FORCE_FAST_ADHESION_MAX_PN ((int32_t)1 << 26)

typedef struct {
    int32_t normal_gain_pn_per_v;   /* k_n K_n, pN/V (normal force per volt of S_n) */
    int32_t lateral_gain_pn_per_v;  /* k_theta K_l / h, pN/V (lateral force per volt of S_l) */
    q30_t two_h_over_l;             /* 2h/l, 2.30 */
    q30_t mu;                       /* tip-substrate friction coefficient, 2.30 */
    int32_t adhesion_pn;            /* F_adh, pN */
    bool fast;                      /* gains <= FW_FORCE_FAST_GAIN_MAX_PN_PER_V, adhesion <=
                                       FW_FORCE_FAST_ADHESION_MAX_PN: fw_force_solve_fast_pn valid */
} fw_force_t;

/* The first rule the arguments break: gains > 0 (FW_RULE_FORCE_GAINS);
 * h > 0, l > 0 (FW_RULE_LEVER_POSITIVE); h < l (FW_RULE_TIP_SHORTER_THAN_LEVER);
 * mu in [0, 1e6 ppm] (FW_RULE_MU_RANGE); adhesion >= 0 (FW_RULE_ADHESION);
 * mu 2h/l <= 1/2 in 2.30 (FW_RULE_MU_2H_OVER_L). */
fw_rule_t fw_force_check(int32_t normal_gain_pn_per_v, int32_t lateral_gain_pn_per_v,
                         int32_t tip_height_nm, int32_t lever_length_nm, int32_t mu_ppm,
                         int32_t adhesion_pn);

/* Validates with fw_force_check (its rule's status, instance untouched). */
fw_status_t fw_force_init(fw_force_t *f, int32_t normal_gain_pn_per_v, int32_t lateral_gain_pn_per_v,
                          int32_t tip_height_nm, int32_t lever_length_nm,
                          int32_t mu_ppm, int32_t adhesion_pn);

/* A force term with 8 extra fraction bits from a gain (pN/V) and a signal
 * (9.23 V): round(gain S / 2^15), F_y (gain k_theta K_l / h, S_l) or
 * N = k_n K_n S_n. Scaling and overflow: |gain S| < 2^62 in 64 bits. */
static inline int64_t fw_force_term8(int32_t gain_pn_per_v, q23_t s_v)
{
    return fw_math_rshift_round_i64((int64_t)gain_pn_per_v * s_v, FW_Q23_FRAC - FW_FORCE_XFRAC);
}

/* The friction fallback F_x,fb = -mc (N + F_adh) / (1 - mc 2h/l) in pN,
 * from n_pn = k_n K_n S_n (pN) and mc = mu cos theta (2.30, |mc| <= 2^30).
 * Scaling and overflow: den = 2^30 - (mc 2h/l >> 30) lies in
 * [2^29, 3 2^29] (init keeps mu 2h/l <= 1/2); |mc (N + F_adh)| <=
 * 2^30 2^32 = 2^62; one 64-bit division, rounded half away from zero;
 * |result| < 2^34. */
static inline int64_t fw_force_fallback_pn(const fw_force_t *f, int32_t n_pn, int64_t mc)
{
    int64_t den = FW_Q30_ONE - fw_math_asr_i64(mc * f->two_h_over_l, FW_Q30_FRAC);
    int64_t num = -mc * ((int64_t)n_pn + f->adhesion_pn);
    /* den > 0, C99 truncates: with num = q den + r (0 <= r < den) for
     * num >= 0, (num + floor(den / 2)) / den = q + (r >= den / 2), i.e.
     * rounded half up; for num < 0 the same on -num, negated (|num| +
     * den / 2 < 2^63) */
    int64_t half = den >> 1;
    return (num + (num < 0 ? -half : half)) / den;
}

/* u = tan^2 theta = y^2 / x^2 in 2.30 below S_HI (u < 1/15 < 2^-3.9). */
#define FW_FORCE_U_FRAC 30
/* (1 + u)^(-1/2) ~ 1 + u (a1 + u (a2 + u (a3 + u a4))) on u in [0, 1/15],
 * 2.30: the cubic (f(u) - 1) / u interpolated at the four Chebyshev nodes
 * of [0, 1/15]; |error| < 2.2e-9, exact at u = 0. */
#define FW_FORCE_COS_A1 (-536870876)
#define FW_FORCE_COS_A2 402635780
#define FW_FORCE_COS_A3 (-334225590)
#define FW_FORCE_COS_A4 261126907
/* S_LO = 1/8 and the blend span S_HI - S_LO = 1/8 in 2.30; S_HI = 1/4, the
 * |sin| of the angle to the lever's axis below which F_x is not wholly
 * observed (the host's check warnings and the frame's cone read it here). */
#define FW_FORCE_SIN_LO_Q30 ((int64_t)1 << 27)
#define FW_FORCE_BLEND_SPAN_LOG2_Q30 27
#define FW_FORCE_SIN_HI_Q30 (FW_FORCE_SIN_LO_Q30 + ((int64_t)1 << FW_FORCE_BLEND_SPAN_LOG2_Q30))
#define FW_FORCE_BLEND_SPLIT 24

/* u = y^2 / x^2 in 2.30, truncated, from the squares x2 = x^2 > 0 and
 * y2 = y^2 <= 2^30 (|y| <= 2^15) with 15 y2 < x2 (below S_HI).
 * Scaling and overflow: y2 2^30 <= 2^60; one 64-bit division; u < 2^30 / 15. */
static inline int64_t fw_force_tan2_q30(int64_t x2, int64_t y2)
{
    return y2 * ((int64_t)1 << FW_FORCE_U_FRAC) / x2;
}

/* |cos theta| (2.30) below S_HI from u = tan^2 theta (2.30, [0, 2^30 / 15)).
 * Scaling and overflow: Horner products |p u| < 2^30 2^26.1 in 64 bits;
 * result in (2^29.9, 2^30]. */
static inline int64_t fw_force_abs_cos_from_u_q30(int64_t u)
{
    int64_t p = FW_FORCE_COS_A4;
    p = FW_FORCE_COS_A3 + fw_math_asr_i64(p * u, FW_Q30_FRAC);
    p = FW_FORCE_COS_A2 + fw_math_asr_i64(p * u, FW_Q30_FRAC);
    p = FW_FORCE_COS_A1 + fw_math_asr_i64(p * u, FW_Q30_FRAC);
    return FW_Q30_ONE + fw_math_asr_i64(p * u, FW_Q30_FRAC);
}

/* mc = mu cos theta (2.30) from |cos theta| (2.30) and the sign of x,
 * floor((+-mu) |c| / 2^30): the sign goes on mu, the same product as
 * mu (+-|c|). |mu| <= 2^30 (init), so |mc| <= 2^30. */
static inline int64_t fw_force_mu_cos_q30(const fw_force_t *f, int64_t abs_c, int32_t x)
{
    int64_t mu = (x < 0) ? -(int64_t)f->mu : f->mu;
    return fw_math_asr_i64(mu * abs_c, FW_Q30_FRAC);
}

/* |sin theta| (2.30) = |y| |cos theta| / |x|, truncated, for the blend's
 * weight; x != 0, |x|, |y| <= 2^15, 0 <= abs_c <= 2^30.
 * Scaling and overflow: |y| |c| <= 2^45; one 64-bit division. */
static inline int64_t fw_force_abs_sin_q30(int32_t x, int32_t y, int64_t abs_c)
{
    int64_t ax = (x < 0) ? -(int64_t)x : x;
    int64_t ay = (y < 0) ? -(int64_t)y : y;
    return fw_math_div_trunc_i64_by_small(ay * abs_c, (int32_t)ax);
}

/* The blend of F_x,fb and F_x,cot for S_LO <= |sin theta| < S_HI (pN), the
 * only one: n_pn = k_n K_n S_n, fx8 = F_x,cot with 8 fraction bits
 * (|fx8| < 2^50), mc = mu cos theta and as = |sin theta| (2.30).
 * Scaling and overflow: F_x,fb with 8 fraction bits (as
 * fw_force_fallback_pn, truncated): q 2^8 + (r 2^8) / den, |r| < den <
 * 2^31; F_x = F_x,fb + w (F_x,cot - F_x,fb), w = (|s| - 1/8) / (1/8) in
 * 2.30 / 2^27, the product w diff (|w| <= 2^27, |diff| < 2^51, 8 fraction
 * bits) is formed from diff = dh 2^24 + dl, dl in [0, 2^24):
 * |w dh| < 2^54, w dl < 2^51, and floor((w dh 2^24 + w dl) / 2^27) =
 * floor(w dh / 8) + floor(((w dh mod 8) 2^24 + w dl) / 2^27), exact;
 * rounded to pN once. */
static FW_ALWAYS_INLINE int64_t fw_force_blend_pn(const fw_force_t *f, int32_t n_pn, int64_t fx8, int64_t mc,
                                                  int64_t as)
{
    int64_t den = FW_Q30_ONE - fw_math_asr_i64(mc * f->two_h_over_l, FW_Q30_FRAC);
    int64_t num = -mc * ((int64_t)n_pn + f->adhesion_pn);
    int64_t fb = num / den;
    int64_t w;
    int64_t diff8;
    int64_t dh;
    int64_t hi;
    int64_t lo;
    int64_t hq;
    fb = fb * ((int64_t)1 << FW_FORCE_XFRAC) + (num - fb * den) * ((int64_t)1 << FW_FORCE_XFRAC) / den;
    w = as - FW_FORCE_SIN_LO_Q30;
    w = (w < 0) ? 0 : ((w > FW_FORCE_SIN_LO_Q30) ? FW_FORCE_SIN_LO_Q30 : w);
    diff8 = fx8 - fb;
    dh = fw_math_asr_i64(diff8, FW_FORCE_BLEND_SPLIT);
    hi = w * dh;
    lo = w * (diff8 - dh * ((int64_t)1 << FW_FORCE_BLEND_SPLIT));
    hq = fw_math_asr_i64(hi, FW_FORCE_BLEND_SPAN_LOG2_Q30 - FW_FORCE_BLEND_SPLIT);
    return fw_math_rshift_round_i64(
        fb + hq
            + fw_math_asr_i64((hi - hq * ((int64_t)1 << (FW_FORCE_BLEND_SPAN_LOG2_Q30 - FW_FORCE_BLEND_SPLIT)))
                                  * ((int64_t)1 << FW_FORCE_BLEND_SPLIT) + lo,
                              FW_FORCE_BLEND_SPAN_LOG2_Q30),
        FW_FORCE_XFRAC);
}

/* F_x (pN) in every zone, the solver's one copy of the zones, from n8 =
 * k_n K_n S_n and fy8 = F_y with 8 fraction bits (|n8|, |fy8| < 2^47), the
 * direction (|x|, |y| <= 2^15) and its squares x2 = x^2, y2 = y^2:
 *   15 y2 > x2         cot zone, F_x,cot = F_y x / y (y != 0 there), no flag;
 *   x2 = 0 (y2 = 0)    the zero vector is theta = 90 deg: 0, no flag;
 *   63 y2 < x2         fallback alone, FW_FLAG_FX_UNOBSERVABLE;
 *   else               blend (fw_force_blend_pn), FW_FLAG_FX_UNOBSERVABLE.
 * (|sin theta| >= 1/4 <=> 15 y^2 >= x^2 and >= 1/8 <=> 63 y^2 >= x^2,
 * exact; x^2 = 15 y^2 has no integer solution but (0, 0).)
 * Below S_HI, N is first rounded to pN and saturated to int32 (*sat).
 * Scaling and overflow: |F_y x| < 2^62, |F_x,cot| < 2^50 (8 fraction bits,
 * |x / y| < 8 where it is formed); the fallback and blend as above. */
static FW_ALWAYS_INLINE int64_t fw_force_fx_pn(const fw_force_t *f, int64_t n8, int64_t fy8, int32_t x,
                                               int32_t y, int64_t x2, int64_t y2, uint32_t *flags,
                                               bool *sat)
{
    int32_t n;
    int64_t c;
    int64_t mc;
    if (FW_LIKELY(15 * y2 > x2)) {
        return fw_math_rshift_round_i64(fw_math_div_trunc_i64_by_small(fy8 * x, y), FW_FORCE_XFRAC);
    }
    if (x2 == 0) {
        return 0;
    }
    *flags |= FW_FLAG_FX_UNOBSERVABLE;
    n = fw_math_sat_i32(fw_math_rshift_round_i64(n8, FW_FORCE_XFRAC), sat);
    c = fw_force_abs_cos_from_u_q30(fw_force_tan2_q30(x2, y2));
    mc = fw_force_mu_cos_q30(f, c, x);
    if (63 * y2 < x2) {
        return fw_force_fallback_pn(f, n, mc);
    }
    return fw_force_blend_pn(f, n, fw_math_div_trunc_i64_by_small(fy8 * x, y), mc, fw_force_abs_sin_q30(x, y, c));
}

/* F_z with 8 fraction bits from N (8 fraction bits) and the clamped F_x
 * (pN): n8 - round((2h/l) F_x / 2^22). Scaling and overflow:
 * |(2h/l) F_x| < 2^31 2^31 = 2^62. */
static FW_ALWAYS_INLINE int64_t fw_force_fz8(const fw_force_t *f, int64_t n8, int32_t fx_pn)
{
    return n8 - fw_math_rshift_round_i64((int64_t)f->two_h_over_l * fx_pn, FW_Q30_FRAC - FW_FORCE_XFRAC);
}

/* Force in frame C, pN, from S_n, S_l (9.23 V) and a direction that already
 * satisfies |dir_x|, |dir_y| <= 2^15 (fw_theta leaves it so); valid
 * pointers, no argument checks: the checked per-sample path. Adds
 * FW_FLAG_FX_UNOBSERVABLE and FW_FLAG_SAT_FORCE to *flags as they happen.
 * Scaling and overflow: gain * S < 2^62 >> 15 leaves F_y, N < 2^47 (8
 * fraction bits); the zones as fw_force_fx_pn; F_x clamped to int32 before
 * F_z = N - (2h/l) F_x (fw_force_fz8); every output saturated to int32
 * with FW_FLAG_SAT_FORCE. Error against the reference model of the same
 * equations given the same vector: <= 1 pN (tests/firmware/test_force.c
 * sweeps assert it and print the worst). */
static inline void fw_force_solve_fit_pn(const fw_force_t *f, q23_t sn_v, q23_t sl_v, int32_t dir_x,
                                         int32_t dir_y, int32_t force_c_pn[3], uint32_t *flags)
{
    bool sat = false;
    int64_t fy8 = fw_force_term8(f->lateral_gain_pn_per_v, sl_v);
    int64_t n8 = fw_force_term8(f->normal_gain_pn_per_v, sn_v);
    int32_t fx32 = fw_math_sat_i32(fw_force_fx_pn(f, n8, fy8, dir_x, dir_y, (int64_t)dir_x * dir_x,
                                                  (int64_t)dir_y * dir_y, flags, &sat),
                                   &sat);
    force_c_pn[0] = fx32;
    force_c_pn[1] = fw_math_sat_i32(fw_math_rshift_round_i64(fy8, FW_FORCE_XFRAC), &sat);
    force_c_pn[2] = fw_math_sat_i32(fw_math_rshift_round_i64(fw_force_fz8(f, n8, fx32), FW_FORCE_XFRAC), &sat);
    if (sat) {
        *flags |= FW_FLAG_SAT_FORCE;
    }
}

/* fw_force_solve_fit_pn for an instance with fast set (init: k_n K_n,
 * k_theta K_l / h <= 2^18 pN/V, F_adh <= 2^26 pN) and signals within
 * +-20 V (|S| <= 20 2^23, as fw_acq_take_code_q23 returns them): the same
 * force and flags, without the int32 clamps, which cannot act there. It
 * takes the two force terms with 8 fraction bits, n8 = N = k_n K_n S_n and
 * fy8 = F_y, as fw_force_term8 forms them (the card's fast path forms the
 * same values straight from the ADC codes, fw_acq_gain), and the squares
 * x2 = dir_x^2, y2 = dir_y^2, which the caller has formed already.
 * Scaling and overflow: |gain S| <= 2^18 20 2^23 < 2^45.4, >> 15 rounded:
 * |F_y|, |N| < 2^30.4 with 8 fraction bits (< 2^22.4 pN), so N needs no
 * clamp; cot zone |x / y| < 15^(1/2): |F_x,cot| < 2^24.4 pN; blend zone
 * |x / y| < 63^(1/2): |F_x,cot| < 2^25.4 pN; fallback |F_x,fb| <=
 * |N + F_adh| / (1/2) < 2^27.2 pN; every blend lies between the two.
 * |(2h/l) F_x| < 2^31 2^27.2 in 64 bits, so |F_z| < 2^28.3 pN. All outputs
 * < 2^29 pN: no clamp, no FW_FLAG_SAT_FORCE. Inline (per sample). */
static FW_ALWAYS_INLINE void fw_force_solve_fast_pn(const fw_force_t *f, int64_t n8, int64_t fy8,
                                                    int32_t dir_x, int32_t dir_y, int64_t x2, int64_t y2,
                                                    int32_t force_c_pn[3], uint32_t *flags)
{
    bool no_clamp = false;   /* fw_force_fx_pn's clamp of N cannot act here */
    int32_t fx32 = (int32_t)fw_force_fx_pn(f, n8, fy8, dir_x, dir_y, x2, y2, flags, &no_clamp);
    force_c_pn[0] = fx32;
    force_c_pn[1] = (int32_t)fw_math_rshift_round_i64(fy8, FW_FORCE_XFRAC);
    force_c_pn[2] = (int32_t)fw_math_rshift_round_i64(fw_force_fz8(f, n8, fx32), FW_FORCE_XFRAC);
}

/* Shift (dir_x, dir_y) right together, rounded half up, until both lie in
 * [-2^15, 2^15] (FW_FORCE_DIR_MAX): the larger ends in [2^13, 2^15].
 * Vectors that fit already are left as they are. */
void fw_force_dir_fit(int32_t *dir_x, int32_t *dir_y);

/* Force in frame C, pN, from S_n, S_l (9.23 V) and the direction of motion
 * as a vector (dir_x, dir_y) of any length in frame C (a unit vector in
 * 1.15, (cos theta, sin theta) 2^15, is one): fw_force_dir_fit, then
 * fw_force_solve_fit_pn. (0, 0) is theta = 90 deg (F_x = 0, no flag).
 * FW_ERR_ARG for a NULL pointer. The direction keeps 2^-13 of its angle
 * through the fit. */
fw_status_t fw_force_solve_pn(const fw_force_t *f, q23_t sn_v, q23_t sl_v,
                              int32_t dir_x, int32_t dir_y,
                              int32_t force_c_pn[3], uint32_t *flags);

/* Rotate a frame-C vector into frame A by R(alpha) (eq. 3); z unchanged.
 * cos/sin alpha in 2.30. Saturates (*sat). */
void fw_force_rotate_pn(const int32_t v_c[3], q30_t cos_a, q30_t sin_a,
                        int32_t v_a[3], bool *sat);

/* The lateral force in excess of the tip's own friction on the substrate
 * (pN): |F_xy| - max(0, mu (F_z + F_adh)), from a force on the tip in
 * frame A (pN), with the instance's mu and F_adh. With no object the
 * sliding tip's excess is about 0; an object pushed quasi-statically adds
 * its resistance (physics.md sections 5, 6). The object models take it as
 * their contact force (fw_particles, fw_wire).
 * Scaling and overflow: |F_xy| = floor(sqrt(F_x^2 + F_y^2)) of two squares
 * < 2^62 each in uint64 (< 2^31.5); mu (F_z + F_adh) with |F_z + F_adh| <
 * 2^32 and mu <= 2^30 in 64 bits, rounded; the result lies in
 * (-2^32, 2^31.5). */
int64_t fw_force_lateral_excess_pn(const fw_force_t *f, const int32_t force_pn[3]);

#endif /* FW_FORCE_H */
