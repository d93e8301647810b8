/*
 * fw_force.c - see fw_force.h.
 */
#include "fw_force.h"
#include "fw_math.h"

#define FORCE_BLEND_SPAN (FW_FORCE_SIN_HI_Q15 - FW_FORCE_SIN_LO_Q15)
#define FORCE_MU_G_MAX (FW_Q30_ONE / 2)   /* mu * 2h/l must stay <= 1/2 */

fw_status_t fw_force_init(fw_force_t *f, int32_t kn_pn_per_v, int32_t lat_pn_per_v,
                          int32_t tip_height_nm, int32_t lever_length_nm,
                          int32_t mu_ppm, int32_t adhesion_pn)
{
    int64_t g;
    int64_t mu;
    if (f == NULL || kn_pn_per_v <= 0 || lat_pn_per_v <= 0 || tip_height_nm <= 0
        || lever_length_nm <= 0 || mu_ppm < 0 || mu_ppm > FW_PPM_PER_ONE || adhesion_pn < 0) {
        return FW_ERR_ARG;
    }
    if (tip_height_nm >= lever_length_nm) {
        return FW_ERR_DOMAIN;   /* 2h/l >= 2 does not fit 2.30 and is no lever */
    }
    g = fw_math_div_round_i64((int64_t)2 * tip_height_nm * FW_Q30_ONE, lever_length_nm);
    mu = fw_math_div_round_i64((int64_t)mu_ppm * FW_Q30_ONE, FW_PPM_PER_ONE);
    if (fw_math_asr_i64(mu * g, FW_Q30_FRAC) > FORCE_MU_G_MAX) {
        return FW_ERR_DOMAIN;
    }
    f->kn_pn_per_v = kn_pn_per_v;
    f->lat_pn_per_v = lat_pn_per_v;
    f->two_h_over_l = (q30_t)g;
    f->mu = (q30_t)mu;
    f->adhesion_pn = adhesion_pn;
    f->fast = kn_pn_per_v <= FW_FORCE_FAST_GAIN_MAX_PN_PER_V
              && lat_pn_per_v <= FW_FORCE_FAST_GAIN_MAX_PN_PER_V
              && adhesion_pn <= FW_FORCE_FAST_ADHESION_MAX_PN;
    return FW_OK;
}

fw_status_t fw_force_solve_pn(const fw_force_t *f, q23_t sn_v, q23_t sl_v,
                              q15_t cos_theta, q15_t sin_theta,
                              int32_t force_c_pn[3], uint32_t *flags)
{
    bool sat = false;
    int64_t fy8;
    int64_t n8;
    int32_t n;
    int32_t abs_s;
    int64_t fx = 0;
    int32_t fx32;
    int64_t fz8;
    if (f == NULL || force_c_pn == NULL || flags == NULL) {
        return FW_ERR_ARG;
    }
    if (cos_theta == 0 && sin_theta == 0) {
        sin_theta = FW_Q15_MAX;
    }
    /* F_y and k_n K_n S_n with 8 extra fraction bits: |gain * S| < 2^62,
     * >> 15 leaves < 2^47 */
    fy8 = fw_force_term8(f->lat_pn_per_v, sl_v);
    n8 = fw_force_term8(f->kn_pn_per_v, sn_v);
    n = fw_math_sat_i32(fw_math_rshift_round_i64(n8, FW_FORCE_XFRAC), &sat);
    abs_s = sin_theta < 0 ? -(int32_t)sin_theta : (int32_t)sin_theta;

    if (abs_s >= FW_FORCE_SIN_LO_Q15) {
        /* |cot| <= 8 here: |fy8 * c| < 2^62, quotient < 2^50 */
        fx = fw_math_div_round_i64(fy8 * cos_theta, (int64_t)sin_theta * ((int64_t)1 << FW_FORCE_XFRAC));
    }
    if (abs_s < FW_FORCE_SIN_HI_Q15) {
        /* F_x,fb = -mu c (N + F_adh) / (1 - mu c 2h/l):
         * mc in 2.30 (|mc| <= 1), den in [1/2, 3/2] in 2.30,
         * |mc * load| < 2^30 * 2^32 */
        int64_t mc = fw_math_asr_i64((int64_t)f->mu * cos_theta, FW_Q15_FRAC);
        int64_t fb = fw_force_fallback_pn(f, n, mc);
        if (abs_s < FW_FORCE_SIN_LO_Q15) {
            fx = fb;
        } else {
            /* w < 2^12, |fx| < 2^50, |fb| < 2^34: the sum stays < 2^63 */
            int64_t w = abs_s - FW_FORCE_SIN_LO_Q15;
            fx = fw_math_div_round_i64(w * fx + (FORCE_BLEND_SPAN - w) * fb, FORCE_BLEND_SPAN);
        }
        *flags |= FW_FLAG_FX_UNOBSERVABLE;
    }
    /* F_z from the clamped F_x: |2h/l * fx32| < 2^62 */
    fx32 = fw_math_sat_i32(fx, &sat);
    fz8 = n8 - fw_math_rshift_round_i64((int64_t)f->two_h_over_l * fx32, FW_Q30_FRAC - FW_FORCE_XFRAC);
    force_c_pn[0] = fx32;
    force_c_pn[1] = fw_math_sat_i32(fw_math_rshift_round_i64(fy8, FW_FORCE_XFRAC), &sat);
    force_c_pn[2] = fw_math_sat_i32(fw_math_rshift_round_i64(fz8, FW_FORCE_XFRAC), &sat);
    if (sat) {
        *flags |= FW_FLAG_SAT_FORCE;
    }
    return FW_OK;
}

void fw_force_dir_fit(int32_t *dir_x, int32_t *dir_y)
{
    int64_t x = *dir_x;
    int64_t y = *dir_y;
    uint64_t ax = (uint64_t)(x < 0 ? -x : x);
    uint64_t ay = (uint64_t)(y < 0 ? -y : y);
    if (ax > (uint64_t)FW_FORCE_DIR_MAX || ay > (uint64_t)FW_FORCE_DIR_MAX) {
        int sh = 49 - fw_math_clz_u64(ax | ay);   /* (ax | ay) >> sh in [2^14, 2^15) */
        *dir_x = (int32_t)fw_math_rshift_round_i64(x, sh);
        *dir_y = (int32_t)fw_math_rshift_round_i64(y, sh);
    }
}

fw_status_t fw_force_solve_dir_pn(const fw_force_t *f, q23_t sn_v, q23_t sl_v,
                                  int32_t dir_x, int32_t dir_y,
                                  int32_t force_c_pn[3], uint32_t *flags)
{
    if (f == NULL || force_c_pn == NULL || flags == NULL) {
        return FW_ERR_ARG;
    }
    fw_force_dir_fit(&dir_x, &dir_y);
    fw_force_solve_dir_fit_pn(f, sn_v, sl_v, dir_x, dir_y, force_c_pn, flags);
    return FW_OK;
}

int64_t fw_force_blend_pn(const fw_force_t *f, int32_t n_pn, int64_t fx8, int64_t mc, int64_t as)
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

void fw_force_rotate_pn(const int32_t v_c[3], q30_t cos_a, q30_t sin_a,
                        int32_t v_a[3], bool *sat)
{
    int32_t x;
    int32_t y;
    fw_math_rotate_i32(v_c[0], v_c[1], cos_a, sin_a, &x, &y, sat);
    v_a[0] = x;
    v_a[1] = y;
    v_a[2] = v_c[2];
}

fw_status_t fw_theta_init(fw_theta_t *t, int32_t min_disp_pm)
{
    if (t == NULL || min_disp_pm < 0) {
        return FW_ERR_ARG;
    }
    t->min_disp_pm = (min_disp_pm == 0) ? FW_THETA_MIN_DISP_DEFAULT_PM : min_disp_pm;
    t->min_disp2_pm2 = (uint64_t)t->min_disp_pm * (uint64_t)t->min_disp_pm;
    fw_theta_reset(t);
    return FW_OK;
}

void fw_theta_reset(fw_theta_t *t)
{
    int32_t i;
    for (i = 0; i < FW_THETA_WINDOW; i++) {
        t->x_pm[i] = 0;
        t->y_pm[i] = 0;
    }
    t->pos = 0;
    t->fill = 0;
    t->dir_x = 0;
    t->dir_y = 1;
    t->cos_theta = 0;
    t->sin_theta = FW_Q15_MAX;
    t->known = false;
}

void fw_theta_prime(fw_theta_t *t, const int32_t apex_pm[2])
{
    int32_t i;
    for (i = 0; i < FW_THETA_WINDOW; i++) {
        t->x_pm[i] = apex_pm[0];
        t->y_pm[i] = apex_pm[1];
    }
    t->fill = FW_THETA_WINDOW;
}

void fw_theta_step(fw_theta_t *t, const int32_t apex_pm[2], q30_t cos_a, q30_t sin_a,
                   uint32_t *flags)
{
    cos_a = (cos_a > FW_Q30_ONE) ? FW_Q30_ONE : ((cos_a < -FW_Q30_ONE) ? -FW_Q30_ONE : cos_a);
    sin_a = (sin_a > FW_Q30_ONE) ? FW_Q30_ONE : ((sin_a < -FW_Q30_ONE) ? -FW_Q30_ONE : sin_a);
    if (fw_theta_push_pm(t, apex_pm, cos_a, sin_a, flags)) {
        q15_t c;
        q15_t s;
        if (fw_math_unit_q15(t->dir_x, t->dir_y, &c, &s)) {
            t->cos_theta = c;
            t->sin_theta = s;
        }
    }
}
