/*
 * fw_force.h - force on the tip from the photodiode signals (physics.md
 * section 1, eq. 1a-1c and 3), and the tip's direction of motion.
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
 * with S_LO = 1/8 (7.2 deg) and S_HI = 1/4 (14.5 deg) in 1.15. For
 * |sin theta| < S_HI the flag FW_FLAG_FX_UNOBSERVABLE is set. F_x,cot is
 * only evaluated for |sin theta| >= S_LO, where |cot theta| <= 8, so no
 * division by a vanishing sin theta ever happens.
 *
 * Two entry points: fw_force_solve_pn takes (cos theta, sin theta) in 1.15;
 * fw_force_solve_dir_pn (the per-sample path of fw_board_step) takes the
 * direction of motion as a vector of any length, as fw_theta_push_pm leaves
 * it, and never forms the unit vector where it is not needed: F_x,cot =
 * F_y x / y, the zones are tested on squares, and cos theta (and
 * |sin theta| for the blend) are formed only below S_HI.
 */
#ifndef FW_FORCE_H
#define FW_FORCE_H

#include "fw_types.h"
#include "fw_math.h"

#define FW_FORCE_SIN_LO_Q15 ((q15_t)4096)   /* 1/8 in 1.15 */
#define FW_FORCE_SIN_HI_Q15 ((q15_t)8192)   /* 1/4 in 1.15 */
#define FW_FORCE_XFRAC 8                    /* extra fraction bits of F_y, N, F_z */
#define FW_FORCE_BLEND_LOG2 12              /* S_HI - S_LO = 2^12 in 1.15 */
#define FW_FORCE_DIR_MAX ((int32_t)1 << 15) /* |x|, |y| bound of a direction vector */
/* The fast path's bounds (fw_force_solve_dir_fast_pn): with |S| <= 20 V no
 * force term can leave int32. */
#define FW_FORCE_FAST_GAIN_MAX_PN_PER_V ((int32_t)1 << 18)  /* k_n K_n and k_theta K_l / h */
#define FW_FORCE_FAST_ADHESION_MAX_PN ((int32_t)1 << 26)

typedef struct {
    int32_t kn_pn_per_v;     /* k_n K_n, pN/V */
    int32_t lat_pn_per_v;    /* k_theta K_l / h, pN/V */
    q30_t two_h_over_l;      /* 2h/l, 2.30 */
    q30_t mu;                /* tip-substrate friction coefficient, 2.30 */
    int32_t adhesion_pn;     /* F_adh, pN */
    bool fast;               /* gains <= FW_FORCE_FAST_GAIN_MAX_PN_PER_V, adhesion <=
                                FW_FORCE_FAST_ADHESION_MAX_PN: fw_force_solve_dir_fast_pn valid */
} fw_force_t;

/* Validates: gains > 0; h > 0, l > 0, 2h/l < 2; mu in [0, 1e6 ppm];
 * adhesion >= 0; mu * 2h/l <= 1/2. FW_ERR_ARG / FW_ERR_DOMAIN otherwise. */
fw_status_t fw_force_init(fw_force_t *f, int32_t kn_pn_per_v, int32_t lat_pn_per_v,
                          int32_t tip_height_nm, int32_t lever_length_nm,
                          int32_t mu_ppm, int32_t adhesion_pn);

/* Force in frame C, pN, from S_n, S_l (9.23 V) and the unit direction of
 * motion (cos theta, sin theta) in 1.15 (c = s = 0 is treated as theta =
 * 90 deg: F_x = 0 with no flag). Adds FW_FLAG_FX_UNOBSERVABLE and
 * FW_FLAG_SAT_FORCE to *flags as they happen.
 * Scaling and overflow: gain (pN/V) * S (9.23) in 64 bits (< 2^62), kept
 * with 8 extra fraction bits (< 2^47); cot term F_y c / s from that (< 2^50);
 * fallback in 2.30 with |mu c (N + F_adh)| < 2^62; blend in 64 bits; F_x is
 * clamped to int32 before F_z = N - (2h/l) F_x; every output saturated to
 * int32 with FW_FLAG_SAT_FORCE. Error against the reference model of the
 * same equations: <= 1 pN (test_force sweep, measured 0.998 pN). */
fw_status_t fw_force_solve_pn(const fw_force_t *f, q23_t sn_v, q23_t sl_v,
                              q15_t cos_theta, q15_t sin_theta,
                              int32_t force_c_pn[3], uint32_t *flags);

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

/* Force in frame C, pN, as fw_force_solve_pn, from the direction of motion
 * given as a vector (dir_x, dir_y) of any length in frame C: theta =
 * atan2(dir_y, dir_x). (0, 0) is theta = 90 deg (F_x = 0, no flag).
 * Zones on squares, exact: |sin theta| >= 1/4 <=> 15 y^2 >= x^2 (F_x,cot
 * only, no flag); |sin theta| >= 1/8 <=> 63 y^2 >= x^2 (blend); below,
 * the fallback alone.
 *   F_x,cot = F_y x / y: one 64-bit division (F_y with 8 fraction bits,
 *     truncated: < 2^-8 pN), then rounded to pN.
 *   below 1/4 (fw_force_below_hi_pn): u = tan^2 theta = y^2 / x^2 in
 *     2.30 (u < 1/15, one 64-bit division of the squares, truncated),
 *     |cos theta| = (1 + u)^(-1/2) by the quartic
 *     1 + u (a1 + u (a2 + u (a3 + u a4))) (Chebyshev fit, |error| <
 *     2.2e-9, exact at u = 0), mu cos theta with the sign of x;
 *     F_x,fb = fw_force_fallback_pn (rounded) below 1/8; in the blend
 *     |sin theta| = |y| |cos theta| / |x| in 2.30 (one division),
 *     F_x,fb keeps 8 fraction bits (a second division of the remainder)
 *     and F_x = F_x,fb + w (F_x,cot - F_x,fb) with
 *     w = clamp(|sin| - 1/8, 0, 1/8) / (1/8) in 2.30 / 2^27, the product
 *     split so it never exceeds 64 bits; rounded to pN once.
 * Scaling and overflow: |dir_x|, |dir_y| <= 2^15 (FW_FORCE_DIR_MAX) on the
 * fast path; larger vectors are first shifted right (rounded) until they
 * fit (fw_force_dir_fit), which keeps their direction to 2^-13. Squares
 * <= 2^30, 63 y^2 < 2^36 in 64 bits; gain * S < 2^62 >> 15 leaves F_y,
 * N < 2^47 (8 fraction bits); |F_y x| <= 2^62; |F_x,cot| < 2^50
 * (|x / y| < 8); blend terms < 2^54;
 * F_x clamped to int32 before F_z = N - (2h/l) F_x; every output saturated
 * to int32 with FW_FLAG_SAT_FORCE.
 * Error against the reference model of the same equations, given the same
 * vector (test_force sweep, |x|, |y| <= 2^15): <= 1 pN (measured 0.68 pN). */
fw_status_t fw_force_solve_dir_pn(const fw_force_t *f, q23_t sn_v, q23_t sl_v,
                                  int32_t dir_x, int32_t dir_y,
                                  int32_t force_c_pn[3], uint32_t *flags);

/* Shift (dir_x, dir_y) right together, rounded half up, until both lie in
 * [-2^15, 2^15] (FW_FORCE_DIR_MAX): the larger ends in [2^13, 2^15].
 * Vectors that fit already are left as they are. */
void fw_force_dir_fit(int32_t *dir_x, int32_t *dir_y);

/* u = tan^2 theta = y^2 / x^2 in 2.30 below S_HI (u < 1/15 < 2^-3.9). */
#define FW_FORCE_U_FRAC 30
/* (1 + u)^(-1/2) ~ 1 + u (a1 + u (a2 + u (a3 + u a4))) on u in [0, 1/15],
 * 2.30: the cubic (f(u) - 1) / u interpolated at the four Chebyshev nodes
 * of [0, 1/15]; |error| < 2.2e-9, exact at u = 0. */
#define FW_FORCE_COS_A1 (-536870876)
#define FW_FORCE_COS_A2 402635780
#define FW_FORCE_COS_A3 (-334225590)
#define FW_FORCE_COS_A4 261126907
/* S_LO = 1/8 and the blend span S_HI - S_LO = 1/8 in 2.30 */
#define FW_FORCE_SIN_LO_Q30 ((int64_t)1 << 27)
#define FW_FORCE_BLEND_SPAN_LOG2_Q30 27
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
    return ay * abs_c / ax;
}

/* The blend of F_x,fb and F_x,cot for S_LO <= |sin theta| < S_HI (pN):
 * n_pn = k_n K_n S_n, fx8 = F_x,cot with 8 fraction bits, mc = mu cos
 * theta and as = |sin theta| (2.30). Out of line: the blend zone is a
 * 7 deg band either side of the lever's axis.
 * Scaling and overflow: F_x,fb with 8 fraction bits (as
 * fw_force_fallback_pn, truncated): q 2^8 + (r 2^8) / den, |r| < den <
 * 2^31; F_x = F_x,fb + w (F_x,cot - F_x,fb), w = (|s| - 1/8) / (1/8) in
 * 2.30 / 2^27, the product w diff (|w| <= 2^27, |diff| < 2^51, 8 fraction
 * bits) is formed from diff = dh 2^24 + dl, dl in [0, 2^24):
 * |w dh| < 2^54, w dl < 2^51, and floor((w dh 2^24 + w dl) / 2^27) =
 * floor(w dh / 8) + floor(((w dh mod 8) 2^24 + w dl) / 2^27), exact;
 * rounded to pN once. */
int64_t fw_force_blend_pn(const fw_force_t *f, int32_t n_pn, int64_t fx8, int64_t mc, int64_t as);

/* F_x below S_HI (pN): F_x,fb, blended with F_x,cot = fx8 / 2^8 when
 * blend (|sin theta| >= S_LO). Part of fw_force_solve_dir_pn; requires
 * |x|, |y| <= 2^15, x2 = x^2, y2 = y^2 and 15 y2 < x2 (so x != 0). Inline;
 * the blend itself is out of line (fw_force_blend_pn).
 * Scaling and overflow: u, |cos theta|, mc = mu cos theta and |sin theta|
 * as fw_force_tan2_q30, fw_force_abs_cos_from_u_q30, fw_force_mu_cos_q30,
 * fw_force_abs_sin_q30 (|mc| <= 2^30); then fw_force_fallback_pn or
 * fw_force_blend_pn. */
static FW_ALWAYS_INLINE int64_t fw_force_below_hi_pn(const fw_force_t *f, int32_t n_pn, int64_t fx8,
                                                     int32_t dir_x, int32_t dir_y, int64_t x2, int64_t y2,
                                                     bool blend)
{
    int64_t c = fw_force_abs_cos_from_u_q30(fw_force_tan2_q30(x2, y2));
    int64_t mc = fw_force_mu_cos_q30(f, c, dir_x);
    if (!blend) {
        return fw_force_fallback_pn(f, n_pn, mc);
    }
    return fw_force_blend_pn(f, n_pn, fx8, mc, fw_force_abs_sin_q30(dir_x, dir_y, c));
}

/* A force term with 8 extra fraction bits from a gain (pN/V) and a signal
 * (9.23 V): round(gain S / 2^15), F_y (gain k_theta K_l / h, S_l) or
 * N = k_n K_n S_n. Scaling and overflow: |gain S| < 2^62 in 64 bits. */
static inline int64_t fw_force_term8(int32_t gain_pn_per_v, q23_t s_v)
{
    return fw_math_rshift_round_i64((int64_t)gain_pn_per_v * s_v, FW_Q23_FRAC - FW_FORCE_XFRAC);
}

/* fw_force_solve_dir_pn for a direction that already satisfies
 * |dir_x|, |dir_y| <= 2^15 (fw_theta_push_pm leaves it so) and valid
 * pointers: no argument checks. Inline, the per-sample path. */
static inline void fw_force_solve_dir_fit_pn(const fw_force_t *f, q23_t sn_v, q23_t sl_v,
                                             int32_t dir_x, int32_t dir_y,
                                             int32_t force_c_pn[3], uint32_t *flags)
{
    bool sat = false;
    int64_t fy8 = fw_force_term8(f->lat_pn_per_v, sl_v);
    int64_t n8 = fw_force_term8(f->kn_pn_per_v, sn_v);
    int64_t x2 = (int64_t)dir_x * dir_x;
    int64_t y2 = (int64_t)dir_y * dir_y;
    int64_t fx8 = 0;
    int32_t fx32;
    int64_t fz8;
    if (63 * y2 >= x2 && dir_y != 0) {
        fx8 = fy8 * dir_x / dir_y;
    }
    if (15 * y2 >= x2) {
        fx32 = fw_math_sat_i32(fw_math_rshift_round_i64(fx8, FW_FORCE_XFRAC), &sat);
    } else {
        int32_t n = fw_math_sat_i32(fw_math_rshift_round_i64(n8, FW_FORCE_XFRAC), &sat);
        fx32 = fw_math_sat_i32(fw_force_below_hi_pn(f, n, fx8, dir_x, dir_y, x2, y2, 63 * y2 >= x2), &sat);
        *flags |= FW_FLAG_FX_UNOBSERVABLE;
    }
    /* F_z from the clamped F_x: |2h/l * fx32| < 2^62 */
    fz8 = n8 - fw_math_rshift_round_i64((int64_t)f->two_h_over_l * fx32, FW_Q30_FRAC - FW_FORCE_XFRAC);
    force_c_pn[0] = fx32;
    force_c_pn[1] = fw_math_sat_i32(fw_math_rshift_round_i64(fy8, FW_FORCE_XFRAC), &sat);
    force_c_pn[2] = fw_math_sat_i32(fw_math_rshift_round_i64(fz8, FW_FORCE_XFRAC), &sat);
    if (sat) {
        *flags |= FW_FLAG_SAT_FORCE;
    }
}

/* F_x below S_HI (pN) for an instance with fast set and signals within
 * +-20 V (fw_force_solve_dir_fast_pn's bounds): the value of
 * fw_force_below_hi_pn (fallback below S_LO, blend above; the caller
 * raises FW_FLAG_FX_UNOBSERVABLE), inline with the blend included, for the
 * per-sample path. n8 = k_n K_n S_n and fy8 = F_y with 8 fraction bits;
 * x2 = x^2, y2 = y^2 with 15 y2 < x2 (so x != 0); blend = 63 y2 >= x2
 * (then y != 0).
 * Scaling and overflow: u, cos theta, |sin theta|, mc and the fallback as
 * fw_force_below_hi_pn; in the blend |F_x,fb| < 2^27.2 pN (|N| < 2^22.4,
 * F_adh <= 2^26, den >= 1/2), kept with 8 fraction bits (q 2^8 + (r 2^8) /
 * den, as fw_force_blend_pn, < 2^35.2), F_x,cot = F_y x / y with 8
 * fraction bits (|x / y| <= 63^(1/2): < 2^33.4), so |w (F_x,cot - F_x,fb)|
 * < 2^27 2^35.5 < 2^63: the product is formed in one piece, and
 * floor(w diff / 2^27) is the value fw_force_blend_pn forms from its split
 * product (same floor, exact); rounded to pN once, |F_x| < 2^27.2. */
static FW_ALWAYS_INLINE int32_t fw_force_below_hi_fast_pn(const fw_force_t *f, int64_t n8, int64_t fy8,
                                                          int32_t dir_x, int32_t dir_y, int64_t x2,
                                                          int64_t y2, bool blend)
{
    int32_t n = (int32_t)fw_math_rshift_round_i64(n8, FW_FORCE_XFRAC);
    int64_t c = fw_force_abs_cos_from_u_q30(fw_force_tan2_q30(x2, y2));
    int64_t mc = fw_force_mu_cos_q30(f, c, dir_x);
    int64_t den;
    int64_t num;
    int64_t fb;
    int64_t w;
    if (!blend) {
        return (int32_t)fw_force_fallback_pn(f, n, mc);
    }
    den = FW_Q30_ONE - fw_math_asr_i64(mc * f->two_h_over_l, FW_Q30_FRAC);
    num = -mc * ((int64_t)n + f->adhesion_pn);
    fb = num / den;
    fb = fb * ((int64_t)1 << FW_FORCE_XFRAC) + (num - fb * den) * ((int64_t)1 << FW_FORCE_XFRAC) / den;
    w = fw_force_abs_sin_q30(dir_x, dir_y, c) - FW_FORCE_SIN_LO_Q30;
    w = (w < 0) ? 0 : ((w > FW_FORCE_SIN_LO_Q30) ? FW_FORCE_SIN_LO_Q30 : w);
    return (int32_t)fw_math_rshift_round_i64(
        fb + fw_math_asr_i64(w * (fy8 * dir_x / dir_y - fb), FW_FORCE_BLEND_SPAN_LOG2_Q30), FW_FORCE_XFRAC);
}

/* fw_force_solve_dir_fit_pn for an instance with fast set (init: k_n K_n,
 * k_theta K_l / h <= 2^18 pN/V, F_adh <= 2^26 pN) and signals within
 * +-20 V (|S| <= 20 2^23, as fw_acq_take_code_q23 returns them): the same
 * force and flags, without the int32 clamps, which cannot act there. It
 * takes the two force terms with 8 fraction bits, n8 = N = k_n K_n S_n and
 * fy8 = F_y, as fw_force_term8 forms them (the board forms the same values
 * straight from the ADC codes, fw_acq_gain).
 * Direction as fw_force_solve_dir_fit_pn (|dir_x|, |dir_y| <= 2^15).
 * Zones: 15 y^2 > x^2 is the cot zone less the zero vector (x^2 = 15 y^2
 * has no integer solution but (0, 0)); the zero vector gives F_x = 0 with
 * no flag, as in fw_force_solve_dir_fit_pn.
 * Scaling and overflow: |gain S| <= 2^18 20 2^23 < 2^45.4, >> 15 rounded:
 * |F_y|, |N| < 2^30.4 with 8 fraction bits (< 2^22.4 pN); cot zone
 * |x / y| < 15^(1/2): |F_x,cot| < 2^32.4 (8 fraction bits, 2^24.4 pN);
 * blend zone |x / y| < 63^(1/2): |F_x,cot| < 2^33.4; fallback
 * |F_x,fb| <= |N + F_adh| / (1/2) < 2^27.2 pN; every blend lies between
 * the two. |(2h/l) F_x| < 2^31 2^27.2 in 64 bits, so |F_z| < 2^28.3 pN.
 * All outputs < 2^29 pN: no clamp, no FW_FLAG_SAT_FORCE. Inline (per
 * sample). The caller passes the squares x2 = dir_x^2, y2 = dir_y^2, which
 * it has already formed (fw_board_step's fast path, where this is the
 * force it runs). */
static FW_ALWAYS_INLINE void fw_force_solve_dir_fast_pn(const fw_force_t *f, int64_t n8, int64_t fy8,
                                                        int32_t dir_x, int32_t dir_y, int64_t x2, int64_t y2,
                                                        int32_t force_c_pn[3], uint32_t *flags)
{
    int32_t fx32 = 0;
    if (FW_LIKELY(15 * y2 > x2)) {
        fx32 = (int32_t)fw_math_rshift_round_i64(fy8 * dir_x / dir_y, FW_FORCE_XFRAC);
    } else if (x2 != 0) {
        /* below S_HI; in the blend zone y != 0 (63 y^2 >= x^2 > 0) */
        fx32 = fw_force_below_hi_fast_pn(f, n8, fy8, dir_x, dir_y, x2, y2, 63 * y2 >= x2);
        *flags |= FW_FLAG_FX_UNOBSERVABLE;
    }
    force_c_pn[0] = fx32;
    force_c_pn[1] = (int32_t)fw_math_rshift_round_i64(fy8, FW_FORCE_XFRAC);
    force_c_pn[2] = (int32_t)fw_math_rshift_round_i64(
        n8 - fw_math_rshift_round_i64((int64_t)f->two_h_over_l * fx32, FW_Q30_FRAC - FW_FORCE_XFRAC),
        FW_FORCE_XFRAC);
}

/* Rotate a frame-C vector into frame A by R(alpha) (eq. 3); z unchanged.
 * cos/sin alpha in 2.30. Saturates (*sat). */
void fw_force_rotate_pn(const int32_t v_c[3], q30_t cos_a, q30_t sin_a,
                        int32_t v_a[3], bool *sat);

/* ---- direction of motion ------------------------------------------------
 * theta is estimated from the apex positions (frame A, pm) of the last
 * FW_THETA_WINDOW samples: d = p_now - p_(now - WINDOW + 1), rotated into
 * frame C by R(-alpha). If |d| < min_disp_pm the direction is unknown and the
 * last known direction is held; before any is known, theta = 90 deg
 * (motion across the lever, F_x = 0) and FW_FLAG_THETA_UNKNOWN is set.
 * The length test is exact, on d in frame A (a rotation keeps lengths):
 * dx^2 + dy^2 >= min_disp_pm^2 in 64 bits (min_disp_pm^2 kept by init). */
#define FW_THETA_WINDOW 16
#define FW_THETA_MIN_DISP_DEFAULT_PM 1000

typedef struct {
    int32_t x_pm[FW_THETA_WINDOW];
    int32_t y_pm[FW_THETA_WINDOW];
    int32_t pos;            /* where the next apex goes */
    int32_t fill;           /* 0 after reset, FW_THETA_WINDOW once primed */
    int32_t min_disp_pm;
    uint64_t min_disp2_pm2; /* min_disp_pm^2 */
    int32_t dir_x;          /* latest direction, frame C, pm (|x|, |y| <= 2^15, */
    int32_t dir_y;          /*   scaled down above); (0, 1) before any */
    q15_t cos_theta;        /* latest direction, frame C, 1.15 (fw_theta_step only) */
    q15_t sin_theta;
    bool known;
} fw_theta_t;

fw_status_t fw_theta_init(fw_theta_t *t, int32_t min_disp_pm);
void fw_theta_reset(fw_theta_t *t);

/* Fill the whole window with the first apex after a reset (fill = WINDOW).
 * Then the oldest entry is always the one after pos, and until
 * FW_THETA_WINDOW samples have been pushed it still holds the first apex:
 * d = p_now - p_first, as the window's definition asks, with no count kept
 * per sample. Called by the pushes when fill is 0. */
void fw_theta_prime(fw_theta_t *t, const int32_t apex_pm[2]);

/* Push the apex (frame A) and update the direction vector (dir_x, dir_y)
 * only: the per-sample path (fw_board_step), inline. Returns true when the
 * direction was updated this sample. Sets FW_FLAG_THETA_UNKNOWN in *flags
 * while no direction is known. cos_a, sin_a: alpha in 2.30, as
 * fw_math_sincos_q30 returns them (|cos_a|, |sin_a| <= 2^30, not checked).
 * Scaling and overflow: d in 64 bits, |dx|, |dy| < 2^32; the length test
 * squares components in [-2^31, 2^31) (sum <= 2^63 in uint64); a d with a larger
 * component has moved anyway (min_disp_pm < 2^31) and is halved (floor),
 * which keeps its direction; the rotation c dx + s dy is formed in 64
 * bits (|c dx| + |s dy| <= 2^62) and rounded (half up) to pm. If a
 * component then exceeds 2^15 pm, the unrounded vector is instead shifted
 * right so that the larger component lies in [2^13, 2^15] (one rounding,
 * the direction kept to 2^-13). So |dir_x|, |dir_y| <= 2^15 always, and
 * max(|dir_x|, |dir_y|) >= 1 (|d| >= 1 pm).
 * cos/sin theta are not formed (fw_theta_step does). */
static inline bool fw_theta_push_pm(fw_theta_t *t, const int32_t apex_pm[2], q30_t cos_a,
                                    q30_t sin_a, uint32_t *flags)
{
    int32_t oldest;
    int64_t dx;
    int64_t dy;
    int64_t px;
    int64_t py;
    int64_t cx;
    int64_t cy;
    if (t->fill == 0) {
        fw_theta_prime(t, apex_pm);
    }
    t->x_pm[t->pos] = apex_pm[0];
    t->y_pm[t->pos] = apex_pm[1];
    oldest = (t->pos + 1) & (FW_THETA_WINDOW - 1);
    t->pos = oldest;
    dx = (int64_t)apex_pm[0] - t->x_pm[oldest];
    dy = (int64_t)apex_pm[1] - t->y_pm[oldest];
    if ((((uint64_t)dx + ((uint64_t)1 << 31)) | ((uint64_t)dy + ((uint64_t)1 << 31))) <= UINT32_MAX) {
        if ((uint64_t)(dx * dx) + (uint64_t)(dy * dy) < t->min_disp2_pm2) {
            if (!t->known) {
                *flags |= FW_FLAG_THETA_UNKNOWN;
            }
            return false;
        }
    } else {
        /* |d| >= 2^31 pm > min_disp_pm: halved, direction kept */
        dx = fw_math_asr_i64(dx, 1);
        dy = fw_math_asr_i64(dy, 1);
    }
    /* into frame C: R(-alpha), 2^-30 pm, then rounded to pm */
    px = (int64_t)cos_a * dx + (int64_t)sin_a * dy;
    py = (int64_t)cos_a * dy - (int64_t)sin_a * dx;
    cx = fw_math_rshift_round_i64(px, FW_Q30_FRAC);
    cy = fw_math_rshift_round_i64(py, FW_Q30_FRAC);
    if ((uint64_t)(cx + FW_FORCE_DIR_MAX) > (uint64_t)(2 * FW_FORCE_DIR_MAX)
        || (uint64_t)(cy + FW_FORCE_DIR_MAX) > (uint64_t)(2 * FW_FORCE_DIR_MAX)) {
        /* over 2^15 pm: shift the unrounded vector, one rounding */
        uint64_t m = (uint64_t)(px < 0 ? -px : px) | (uint64_t)(py < 0 ? -py : py);
        int sh = 49 - fw_math_clz_u64(m);   /* m >> sh in [2^14, 2^15), sh > 30 */
        cx = fw_math_rshift_round_i64(px, sh);
        cy = fw_math_rshift_round_i64(py, sh);
    }
    t->dir_x = (int32_t)cx;
    t->dir_y = (int32_t)cy;
    t->known = true;
    return true;
}

/* fw_board_step's fast window: |dx|, |dy| <= 2^14 pm over the window
 * (16 nm; the paper's 200 nm/s at 10 kHz moves 0.3 nm). Inside it the
 * squares sum to <= 2^29 and the rotation's |c dx + s dy| <= 2^30 (|dx| +
 * |dy|) <= 2^45, so |dir_x|, |dir_y| <= 2^15 after rounding and
 * fw_theta_push_pm's range test and scaling cannot act (fw_board.c). */
#define FW_THETA_FAST_WINDOW_PM ((int64_t)1 << 14)

/* Push the apex (frame A) and update the direction: fw_theta_push_pm, then
 * (cos_theta, sin_theta) = fw_math_unit_q15(dir_x, dir_y) when it moved.
 * Sets FW_FLAG_THETA_UNKNOWN in *flags while no direction is known.
 * Any cos_a, sin_a (clamped to [-1, 1]). */
void fw_theta_step(fw_theta_t *t, const int32_t apex_pm[2], q30_t cos_a, q30_t sin_a,
                   uint32_t *flags);

#endif /* FW_FORCE_H */
