/*
 * fw_board16.c - see fw_board16.h.
 */
#include "fw_board16.h"
#include "fw_board.h"
#include "fw_math.h"

#define B16_ONE 32768
#define B16_Q14_ONE 16384
#define B16_COT_FRAC 12
#define B16_DIR_LO (1 << 13)               /* direction normalised into [2^13, 2^14) */
#define B16_SIN_LO 4096                    /* 1/8 in 1.15 */
#define B16_BLEND_LOG2 3                   /* w = (|s| - 1/8) 8 */
#define B16_FS_V 10                        /* the 1.15 signals' full scale, volts */
#define B16_MIN_DISP_MAX_PM ((int32_t)1 << 14)

/* x >> n rounded half up (n >= 1), floor(x / 2^n + 1/2); x + 2^(n-1)
 * must fit int32 (every caller's products are below 2^31 - 2^15). */
static int32_t b16_rsh(int32_t x, int n)
{
    return fw_math_asr_i32(x + (1 << (n - 1)), n);
}

/* x (int32) times q (1.15, or m.n with n = frac) >> frac, as two 16 x 16
 * products: x = hi 2^16 + lo, lo in [0, 2^16).
 * Scaling and overflow: |lo q| <= 65535 32768 < 2^31; hi q 2^(16 - frac)
 * stays in int32 for |x| < 2^(31 - 16 + frac) / |q| 2^16 (every caller
 * below keeps |x| within the domain's 2^24 pN); frac in 1..16. */
static int32_t b16_mul_i32(int32_t x, int16_t q, int frac)
{
    int32_t hi = fw_math_asr_i32(x, 16);
    int32_t lo = x & 0xFFFF;
    return hi * q * (1 << (16 - frac)) + b16_rsh(lo * q, frac);
}

/* gain_fs (> 0, < 2^30) = mant 2^k with mant <= INT16_MAX, k >= 0 minimal. */
static void b16_split_gain(int32_t gain_fs, int16_t *mant, int16_t *k)
{
    int16_t e = 0;
    while (((gain_fs + ((1 << e) >> 1)) >> e) > INT16_MAX) {
        e++;
    }
    *mant = (int16_t)((gain_fs + ((1 << e) >> 1)) >> e);
    *k = e;
}

static int16_t b16_from_q30(q30_t v)
{
    int32_t r = b16_rsh(v, 15);
    return (int16_t)(r > INT16_MAX ? INT16_MAX : r);
}

fw_rule_t fw_board16_check(const fw_board_config_t *cfg)
{
    fw_rule_t rule = fw_board_check(cfg);
    int32_t md;
    if (rule != FW_RULE_OK) {
        return rule;
    }
    if (cfg->filter_log2 != 0) {
        return FW_RULE_ADC_FILTER;
    }
    md = (cfg->theta_min_disp_pm == 0) ? FW_THETA_MIN_DISP_DEFAULT_PM : cfg->theta_min_disp_pm;
    if (cfg->normal_gain_pn_per_v > FW_BOARD16_GAIN_FS_MAX_PN / B16_FS_V
        || cfg->lateral_gain_pn_per_v > FW_BOARD16_GAIN_FS_MAX_PN / B16_FS_V
        || cfg->disp_n_pm_per_v > FW_BOARD16_DISP_MAX_PM_PER_V || cfg->disp_l_pm_per_v > FW_BOARD16_DISP_MAX_PM_PER_V
        || cfg->adhesion_pn > FW_BOARD16_ADHESION_MAX_PN || md >= B16_MIN_DISP_MAX_PM) {
        return FW_RULE_WORD16_RANGE;
    }
    return FW_RULE_OK;
}

fw_status_t fw_board16_init(fw_board16_t *b, const fw_board_config_t *cfg)
{
    q30_t axis[2];
    int32_t cmax;
    int16_t unused;
    int32_t md;
    fw_rule_t rule = fw_board16_check(cfg);
    if (b == NULL) {
        return FW_ERR_ARG;
    }
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    (void)fw_acq_init(&b->acq, cfg->adc_bits, 0);
    b->code_shift = (int16_t)(16 - cfg->adc_bits);
    cmax = cfg->disp_n_pm_per_v > cfg->disp_l_pm_per_v ? cfg->disp_n_pm_per_v : cfg->disp_l_pm_per_v;
    md = (cfg->theta_min_disp_pm == 0) ? FW_THETA_MIN_DISP_DEFAULT_PM : cfg->theta_min_disp_pm;
    /* gains at full scale: < 2^20 (the domain), so k <= 6 */
    b16_split_gain(cfg->normal_gain_pn_per_v * B16_FS_V, &b->n_mant, &b->n_k);
    b16_split_gain(cfg->lateral_gain_pn_per_v * B16_FS_V, &b->lat_mant, &b->lat_k);
    /* offsets at full scale: C 10 V < 2^24.4 pm, so off_k <= 10 (C = 0: k = 0) */
    b16_split_gain(cmax * B16_FS_V, &unused, &b->off_k);
    b->cn_mant = (int16_t)((cfg->disp_n_pm_per_v * B16_FS_V + ((1 << b->off_k) >> 1)) >> b->off_k);
    b->cl_mant = (int16_t)((cfg->disp_l_pm_per_v * B16_FS_V + ((1 << b->off_k) >> 1)) >> b->off_k);
    fw_board_lever_axis_q30(cfg->scan_angle_mdeg, axis);   /* R(alpha), as the 32-bit chain has it */
    b->cos_a = b16_from_q30(axis[0]);
    b->sin_a = b16_from_q30(axis[1]);
    b->two_h_over_l = (int16_t)(((int64_t)2 * cfg->tip_height_nm * B16_ONE + cfg->lever_length_nm / 2)
                                / cfg->lever_length_nm);
    b->mu = (int16_t)(((int64_t)cfg->mu_ppm * B16_ONE + FW_PPM_PER_ONE / 2) / FW_PPM_PER_ONE);
    if (b->mu > INT16_MAX - 1) {
        b->mu = INT16_MAX;   /* mu = 1 is one LSB short of 1.0 in 1.15 */
    }
    b->adhesion_pn = cfg->adhesion_pn;
    b->min_disp2_pm2 = md * md;
    fw_board16_reset(b);
    return FW_OK;
}

void fw_board16_reset(fw_board16_t *b)
{
    int32_t i;
    fw_acq_reset(&b->acq);
    for (i = 0; i < FW_THETA_WINDOW; i++) {
        b->x_pm[i] = 0;
        b->y_pm[i] = 0;
    }
    b->pos = 0;
    b->fill = 0;
    b->cx = 0;
    b->cy = 1;
    b->known = false;
    b->last_sn = 0;
    b->last_sl = 0;
}

/* The ADC code of an input as a 1.15 value of 10 V, and its saturation:
 * the reciprocal kernel alone inside the ADC's fast range (no saturation,
 * no clamp; fw_acq_code_fast), the full quantiser outside it. */
static FW_ALWAYS_INLINE int16_t b16_adc(const fw_board16_t *b, int32_t uv, bool *sat)
{
    int32_t code;
    if (FW_LIKELY(fw_acq_in_fast_range(&b->acq, uv))) {
        code = fw_acq_code_fast(&b->acq, uv);
    } else {
        code = fw_acq_quantize_code(b->acq.bits, uv, sat);
    }
    return (int16_t)(code * (1 << b->code_shift));
}

/* The bending offset of signals (1.15) in units of 2^off_k pm, frame A.
 * Scaling and overflow: |S mant| < 2^30 >> 15 leaves |o| < 2^15; the
 * rotation's |o cos - o sin| < 2^30.5 in int32, >> 15. */
static void b16_offset(const fw_board16_t *b, int16_t sn, int16_t sl, int32_t *ox_a, int32_t *oy_a)
{
    int16_t ox = (int16_t)b16_rsh(sn * b->cn_mant, 15);
    int16_t oy = (int16_t)b16_rsh(sl * b->cl_mant, 15);
    *ox_a = b16_rsh(ox * b->cos_a - oy * b->sin_a, 15);
    *oy_a = b16_rsh(ox * b->sin_a + oy * b->cos_a, 15);
}

/* The window's displacement to the normalised direction in frame C.
 * Scaling and overflow: the difference of two int32 positions in int64,
 * halved while a component reaches 2^30, then shifted right (rounded)
 * until both lie below 2^14 (the squares and the rotation's sums < 2^29);
 * displacements under 2^14 pm are tested against the minimum with
 * 16 x 16 squares, then scaled up into [2^13, 2^14). */
static void b16_theta(fw_board16_t *b, int32_t ax_pm, int32_t ay_pm)
{
    int32_t oldest;
    int64_t dx64;
    int64_t dy64;
    int32_t dx;
    int32_t dy;
    int32_t m;
    int sh;
    int top;
    bool far = false;
    b->x_pm[b->pos] = ax_pm;
    b->y_pm[b->pos] = ay_pm;
    if (b->fill < FW_THETA_WINDOW) {
        b->fill++;
        oldest = 0;
    } else {
        oldest = (b->pos + 1) & (FW_THETA_WINDOW - 1);
    }
    b->pos = (b->pos + 1) & (FW_THETA_WINDOW - 1);
    dx64 = (int64_t)ax_pm - b->x_pm[oldest];
    dy64 = (int64_t)ay_pm - b->y_pm[oldest];
    while (dx64 >= ((int64_t)1 << 30) || dx64 < -((int64_t)1 << 30) || dy64 >= ((int64_t)1 << 30)
           || dy64 < -((int64_t)1 << 30)) {
        dx64 = fw_math_asr_i64(dx64, 1);
        dy64 = fw_math_asr_i64(dy64, 1);
        far = true;   /* moved a long way: far beyond the minimum */
    }
    dx = (int32_t)dx64;
    dy = (int32_t)dy64;
    m = (dx < 0 ? -dx : dx) | (dy < 0 ? -dy : dy);
    if (m == 0) {
        return;
    }
    /* the shift that brings max(|dx|, |dy|) below 2^14 (m's top bit) */
    top = 63 - fw_math_clz_u64((uint64_t)m);
    if (top >= 14) {
        sh = top - 13;
        dx = b16_rsh(dx, sh);
        dy = b16_rsh(dy, sh);
    } else {
        if (!far && dx * dx + dy * dy < b->min_disp2_pm2) {
            /* |d| < 2^14 pm: the minimum displacement test on 16 x 16 products */
            return;
        }
        sh = (top >= 13) ? 0 : 13 - top;   /* scaled up into [2^13, 2^14) */
        dx *= (1 << sh);
        dy *= (1 << sh);
    }
    /* R(-alpha); |d| < 2^14 per axis, so each sum < 2^29 */
    b->cx = (int16_t)b16_rsh(dx * b->cos_a + dy * b->sin_a, 15);
    b->cy = (int16_t)b16_rsh(dy * b->cos_a - dx * b->sin_a, 15);
    b->known = true;
}

/* F_x (pN) from F_y and N (pN) and the direction (fw_board16.h's
 * simplifications). Scaling and overflow: |F_y|, |N| <= 2^20 (the domain);
 * cot in 4.12 (|cot| <= 8: |cx 2^12| < 2^27 / |cy| >= 2^14/8); F_y cot as
 * b16_mul_i32 (< 2^23); below 1/4, t = cy / cx in 1.15 (|t| < 0.26), the
 * series in 1.15, mc = mu cos in 1.15, the fallback's numerator
 * (N + F_adh) mc clamped to FW_BOARD16_FALLBACK_MAX_PN so num 2^14 < 2^31,
 * its denominator 1 - mc 2h/l in 2.14 (>= 1/2); the blend's difference
 * < 2^24 times w in 1.15. */
static int32_t b16_fx(const fw_board16_t *b, int32_t fy_pn, int32_t n_pn, uint32_t *flags)
{
    int32_t cx = b->cx;
    int32_t cy = b->cy;
    int32_t yy = cy * cy;
    int32_t r2 = cx * cx + yy;                 /* < 2^30 */
    int16_t t;
    int32_t t2;
    int32_t inv;
    int16_t c;
    int32_t as;
    int16_t mc;
    int32_t den;
    int32_t num;
    int32_t fx;
    if (yy >= (r2 >> 4)) {                     /* |sin| >= 1/4: eq. 1b */
        int16_t cot = (int16_t)((cx * (1 << B16_COT_FRAC)) / cy);
        return b16_mul_i32(fy_pn, cot, B16_COT_FRAC);
    }
    *flags |= FW_FLAG_FX_UNOBSERVABLE;         /* fallback, maybe blended */
    t = (int16_t)((cy * B16_ONE) / cx);        /* |t| < 0.26 */
    t2 = b16_rsh(t * t, 15);
    inv = B16_ONE - (t2 >> 1) + ((3 * b16_rsh(t2 * t2, 15)) >> 3);
    if (inv > INT16_MAX) {
        inv = INT16_MAX;
    }
    c = (int16_t)(cx < 0 ? -inv : inv);
    as = b16_rsh((t < 0 ? -t : t) * inv, 15);
    mc = (int16_t)b16_rsh(b->mu * c, 15);
    den = B16_Q14_ONE - b16_rsh(mc * b->two_h_over_l, 16);
    num = b16_mul_i32(n_pn + b->adhesion_pn, mc, 15);
    if (num > FW_BOARD16_FALLBACK_MAX_PN || num < -FW_BOARD16_FALLBACK_MAX_PN) {
        num = (num > 0) ? FW_BOARD16_FALLBACK_MAX_PN : -FW_BOARD16_FALLBACK_MAX_PN;
        *flags |= FW_FLAG_SAT_FORCE;
    }
    fx = -(num * B16_Q14_ONE) / den;
    if (yy >= (r2 >> 6)) {                     /* |sin| >= 1/8: blend */
        int32_t cot = (cx * (1 << B16_COT_FRAC)) / cy;
        int32_t w = (as - B16_SIN_LO) * (1 << B16_BLEND_LOG2);
        int32_t fcot;
        cot = cot > INT16_MAX ? INT16_MAX : (cot < -INT16_MAX ? -INT16_MAX : cot);
        w = w < 0 ? 0 : (w > INT16_MAX ? INT16_MAX : w);
        fcot = b16_mul_i32(fy_pn, (int16_t)cot, B16_COT_FRAC);
        fx += b16_mul_i32(fcot - fx, (int16_t)w, 15);
    }
    return fx;
}

/* One sample (inline in the block loop). Scaling and overflow: the signals' terms S mant >> (15 - k)
 * < 2^20 (k <= 6, the domain); the apex piezo + offset 2^off_k in int64,
 * saturated to int32 (FW_FLAG_SAT_POS); eq. 1c and eq. 3 as b16_mul_i32 of
 * values < 2^24. */
static FW_ALWAYS_INLINE void b16_step(fw_board16_t *b, const fw_sample_in_t *in, fw_sample_out_t *out)
{
    bool sat_n = false;
    bool sat_l = false;
    bool sat_pos = false;
    uint32_t flags = 0;
    int16_t sn = b16_adc(b, in->sn_uv, &sat_n);
    int16_t sl = b16_adc(b, in->sl_uv, &sat_l);
    int32_t ox;
    int32_t oy;
    int32_t n_pn = b16_rsh(sn * b->n_mant, 15 - b->n_k);
    int32_t fy_pn = b16_rsh(sl * b->lat_mant, 15 - b->lat_k);
    int32_t fx_pn = 0;
    b16_offset(b, sn, sl, &ox, &oy);
    out->tip_pm[0] = fw_math_sat_i32((int64_t)in->piezo_pm[0] + (int64_t)ox * (1 << b->off_k), &sat_pos);
    out->tip_pm[1] = fw_math_sat_i32((int64_t)in->piezo_pm[1] + (int64_t)oy * (1 << b->off_k), &sat_pos);
    out->tip_pm[2] = in->piezo_pm[2];
    out->sn_code = fw_math_asr_i32(sn, b->code_shift);
    out->sl_code = fw_math_asr_i32(sl, b->code_shift);
    b16_theta(b, out->tip_pm[0], out->tip_pm[1]);
    if (b->known) {
        fx_pn = b16_fx(b, fy_pn, n_pn, &flags);
    } else {
        flags |= FW_FLAG_THETA_UNKNOWN;
    }
    /* eq. 1c and eq. 3 */
    out->force_pn[2] = n_pn - b16_mul_i32(fx_pn, b->two_h_over_l, 15);
    out->force_pn[0] = b16_mul_i32(fx_pn, b->cos_a, 15) - b16_mul_i32(fy_pn, b->sin_a, 15);
    out->force_pn[1] = b16_mul_i32(fx_pn, b->sin_a, 15) + b16_mul_i32(fy_pn, b->cos_a, 15);
    if (sat_n) {
        flags |= FW_FLAG_SAT_SN;
    }
    if (sat_l) {
        flags |= FW_FLAG_SAT_SL;
    }
    if (sat_pos) {
        flags |= FW_FLAG_SAT_POS;
    }
    b->last_sn = sn;
    b->last_sl = sl;
    out->flags = flags;
}

fw_status_t fw_board16_step_block(fw_board16_t *b, const fw_sample_in_t *in, fw_sample_out_t *out, size_t n)
{
    size_t i;
    if (b == NULL || ((in == NULL || out == NULL) && n != 0)) {
        return FW_ERR_ARG;
    }
    for (i = 0; i < n; i++) {
        b16_step(b, &in[i], &out[i]);
    }
    return FW_OK;
}

void fw_board16_offset_pm(const fw_board16_t *b, int32_t off_pm[2])
{
    int32_t ox;
    int32_t oy;
    b16_offset(b, b->last_sn, b->last_sl, &ox, &oy);
    off_pm[0] = ox * (1 << b->off_k);
    off_pm[1] = oy * (1 << b->off_k);
}
