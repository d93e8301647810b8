/*
 * bench_q15.c - see bench_q15.h.
 */
#include "bench_q15.h"
#include "fw_math.h"

#define Q15_FS_UV 10000000                 /* +-10 V in microvolts */
#define Q15_FS_POW2 7                      /* 10^7 = 2^7 * 78125 */
#define Q15_FS_ODD_UV (Q15_FS_UV >> Q15_FS_POW2)
#define Q15_ADC_SHIFT (15 - Q15_FS_POW2)   /* code = |uv| 2^8 / 78125 */
#define Q15_ONE 32768
#define Q14_ONE 16384
#define Q15_COT_FRAC 12
#define Q15_DIR_LO (1 << 13)               /* direction normalised into [2^13, 2^14) */
#define Q15_SIN_LO 4096                    /* 1/8 */
#define Q15_BLEND_LOG2 3                   /* w = (|s| - 1/8) * 8 */
#define Q15_FB_MAX_PN 131071               /* fallback numerator clamp: << 14 fits int32 */

/* x >> n rounded half up (n >= 1; arithmetic shift on the host's int32). */
static int32_t q15_rsh(int32_t x, int n)
{
    return (x + (1 << (n - 1))) >> n;
}

/* x (int32) * q (1.15 or m.n with n = frac) >> frac, with two 16 x 16
 * products: x = hi 2^16 + lo, lo unsigned.
 * Scaling and overflow: |lo q| <= 65535 * 32768 < 2^31; hi q 2^(16 - frac)
 * wraps if the result does not fit int32 (callers keep it in range).
 * frac in 1..16. */
static int32_t q15_mul_i32(int32_t x, int16_t q, int frac)
{
    int32_t hi = x >> 16;
    int32_t lo = x & 0xFFFF;
    return hi * q * (1 << (16 - frac)) + q15_rsh(lo * q, frac);
}

/* gain_fs (> 0) = mant 2^k with mant < 2^15, k >= 0 minimal. */
static void q15_split_gain(int32_t gain_fs, int16_t *mant, int16_t *k)
{
    int16_t e = 0;
    while (((gain_fs + ((1 << e) >> 1)) >> e) > INT16_MAX) {
        e++;
    }
    *mant = (int16_t)((gain_fs + ((1 << e) >> 1)) >> e);
    *k = e;
}

static int16_t q15_from_q30(q30_t v)
{
    int32_t r = q15_rsh(v, 15);
    return (int16_t)(r > INT16_MAX ? INT16_MAX : r);
}

void bench_q15_init(bench_q15_t *p, const fw_board_config_t *cfg)
{
    q30_t s;
    q30_t c;
    int32_t cmax = cfg->disp_n_pm_per_v > cfg->disp_l_pm_per_v ? cfg->disp_n_pm_per_v : cfg->disp_l_pm_per_v;
    int16_t unused;
    int32_t md = cfg->theta_min_disp_pm == 0 ? FW_THETA_MIN_DISP_DEFAULT_PM : cfg->theta_min_disp_pm;
    q15_split_gain(cfg->normal_gain_pn_per_v * 10, &p->n_mant, &p->n_k);
    q15_split_gain(cfg->lateral_gain_pn_per_v * 10, &p->lat_mant, &p->lat_k);
    q15_split_gain(cmax * 10, &unused, &p->off_k);
    p->cn_mant = (int16_t)((cfg->disp_n_pm_per_v * 10 + ((1 << p->off_k) >> 1)) >> p->off_k);
    p->cl_mant = (int16_t)((cfg->disp_l_pm_per_v * 10 + ((1 << p->off_k) >> 1)) >> p->off_k);
    fw_math_sincos_q30(fw_math_bam_from_mdeg(cfg->scan_angle_mdeg % FW_MDEG_PER_TURN - 270000), &s, &c);
    p->cos_a = q15_from_q30(c);
    p->sin_a = q15_from_q30(s);
    p->two_h_over_l = (int16_t)(((int64_t)2 * cfg->tip_height_nm * Q15_ONE + cfg->lever_length_nm / 2)
                                / cfg->lever_length_nm);
    p->mu = (int16_t)(((int64_t)cfg->mu_ppm * Q15_ONE + FW_PPM_PER_ONE / 2) / FW_PPM_PER_ONE);
    p->adhesion_pn = cfg->adhesion_pn;
    p->min_disp2_pm2 = md * md;
    bench_q15_reset(p);
}

void bench_q15_reset(bench_q15_t *p)
{
    int32_t i;
    for (i = 0; i < FW_THETA_WINDOW; i++) {
        p->x_pm[i] = 0;
        p->y_pm[i] = 0;
    }
    p->pos = 0;
    p->fill = 0;
    p->cx = 0;
    p->cy = 1;
    p->known = 0;
}

/* The card's ADC: 16-bit code (1.15 of 10 V), round half away from zero,
 * clamped. |uv| 2^8 <= 2.56e9 fits uint32. */
static int16_t q15_adc(int32_t uv)
{
    uint32_t mag;
    uint32_t code;
    if (uv > Q15_FS_UV) {
        uv = Q15_FS_UV;
    }
    if (uv < -Q15_FS_UV) {
        uv = -Q15_FS_UV;
    }
    mag = (uint32_t)(uv < 0 ? -uv : uv);
    code = ((mag << Q15_ADC_SHIFT) + Q15_FS_ODD_UV / 2u) / Q15_FS_ODD_UV;
    if (uv >= 0) {
        return (int16_t)(code > INT16_MAX ? INT16_MAX : code);
    }
    return (int16_t)(-(int32_t)code);
}

/* Window displacement -> normalised direction in frame C. */
static void q15_theta(bench_q15_t *p, int32_t ax_pm, int32_t ay_pm)
{
    int32_t oldest;
    int32_t dx;
    int32_t dy;
    int32_t m;
    int sh = 0;
    p->x_pm[p->pos] = ax_pm;
    p->y_pm[p->pos] = ay_pm;
    if (p->fill < FW_THETA_WINDOW) {
        p->fill++;
        oldest = 0;
    } else {
        oldest = (p->pos + 1) & (FW_THETA_WINDOW - 1);
    }
    p->pos = (p->pos + 1) & (FW_THETA_WINDOW - 1);
    dx = ax_pm - p->x_pm[oldest];
    dy = ay_pm - p->y_pm[oldest];
    m = (dx < 0 ? -dx : dx) | (dy < 0 ? -dy : dy);
    if (m == 0) {
        return;
    }
    while ((m >> sh) >= 2 * Q15_DIR_LO) {
        sh++;
    }
    if (sh == 0) {
        /* |d| < 2^14 pm: the minimum displacement test in 16 x 16 products */
        if (dx * dx + dy * dy < p->min_disp2_pm2) {
            return;
        }
        while ((m << sh) < Q15_DIR_LO) {
            sh++;
        }
        dx *= (1 << sh);
        dy *= (1 << sh);
    } else {
        dx = q15_rsh(dx, sh);
        dy = q15_rsh(dy, sh);
    }
    /* R(-alpha); |d| < 2^14 per axis, so each sum < 2^29 */
    p->cx = (int16_t)q15_rsh(dx * p->cos_a + dy * p->sin_a, 15);
    p->cy = (int16_t)q15_rsh(dy * p->cos_a - dx * p->sin_a, 15);
    p->known = 1;
}

void bench_q15_step(bench_q15_t *p, const fw_sample_in_t *in, int32_t force_a_pn[3])
{
    int16_t sn = q15_adc(in->sn_uv);
    int16_t sl = q15_adc(in->sl_uv);
    /* compensation: offset in units of 2^off_k pm, rotated by R(alpha);
     * |o| < 2^15 and |cos| + |sin| <= sqrt 2, so each sum < 2^31 */
    int16_t ox = (int16_t)q15_rsh(sn * p->cn_mant, 15);
    int16_t oy = (int16_t)q15_rsh(sl * p->cl_mant, 15);
    int32_t ax = q15_rsh(ox * p->cos_a - oy * p->sin_a, 15);
    int32_t ay = q15_rsh(ox * p->sin_a + oy * p->cos_a, 15);
    int32_t n_pn = q15_rsh(sn * p->n_mant, 15 - p->n_k);
    int32_t fy_pn = q15_rsh(sl * p->lat_mant, 15 - p->lat_k);
    int32_t fx_pn = 0;
    q15_theta(p, in->piezo_pm[0] + ax * (1 << p->off_k), in->piezo_pm[1] + ay * (1 << p->off_k));

    if (p->known) {
        int32_t cx = p->cx;
        int32_t cy = p->cy;
        int32_t yy = cy * cy;
        int32_t r2 = cx * cx + yy;                 /* < 2^30 */
        if (yy >= (r2 >> 4)) {                     /* |sin| >= 1/4: eq. 1b */
            int16_t cot = (int16_t)((cx * (1 << Q15_COT_FRAC)) / cy);
            fx_pn = q15_mul_i32(fy_pn, cot, Q15_COT_FRAC);
        } else {                                   /* fallback, maybe blended */
            int16_t t = (int16_t)((cy * Q15_ONE) / cx);   /* |t| < 0.26 */
            int32_t t2 = q15_rsh(t * t, 15);
            int32_t inv = Q15_ONE - (t2 >> 1) + ((3 * q15_rsh(t2 * t2, 15)) >> 3);
            int16_t c;
            int32_t as;
            int16_t mc;
            int32_t den;
            int32_t num;
            if (inv > INT16_MAX) {
                inv = INT16_MAX;
            }
            c = (int16_t)(cx < 0 ? -inv : inv);
            as = q15_rsh((t < 0 ? -t : t) * inv, 15);
            mc = (int16_t)q15_rsh(p->mu * c, 15);
            den = Q14_ONE - q15_rsh(mc * p->two_h_over_l, 16);
            num = q15_mul_i32(n_pn + p->adhesion_pn, mc, 15);
            if (num > Q15_FB_MAX_PN) {
                num = Q15_FB_MAX_PN;
            }
            if (num < -Q15_FB_MAX_PN) {
                num = -Q15_FB_MAX_PN;
            }
            fx_pn = -(num * Q14_ONE) / den;
            if (yy >= (r2 >> 6)) {                 /* |sin| >= 1/8: blend */
                int32_t cot = (cx * (1 << Q15_COT_FRAC)) / cy;
                int32_t w = (as - Q15_SIN_LO) * (1 << Q15_BLEND_LOG2);
                int32_t fcot;
                cot = cot > INT16_MAX ? INT16_MAX : (cot < -INT16_MAX ? -INT16_MAX : cot);
                w = w < 0 ? 0 : (w > INT16_MAX ? INT16_MAX : w);
                fcot = q15_mul_i32(fy_pn, (int16_t)cot, Q15_COT_FRAC);
                fx_pn += q15_mul_i32(fcot - fx_pn, (int16_t)w, 15);
            }
        }
    }
    /* eq. 1c and eq. 3 */
    force_a_pn[2] = n_pn - q15_mul_i32(fx_pn, p->two_h_over_l, 15);
    force_a_pn[0] = q15_mul_i32(fx_pn, p->cos_a, 15) - q15_mul_i32(fy_pn, p->sin_a, 15);
    force_a_pn[1] = q15_mul_i32(fx_pn, p->sin_a, 15) + q15_mul_i32(fy_pn, p->cos_a, 15);
}
