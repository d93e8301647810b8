/*
 * fw_calib.c - see fw_calib.h.
 */
#include "fw_calib.h"
#include "fw_math.h"

/* |rho| must exceed 1 by this fraction (2^-10). */
#define CALIB_RHO_MARGIN_LOG2 10
/* the C_n fit's denominator is reduced below 2^31 before the division */
#define CALIB_DEN_BITS 31
/* |slope| < 128 in 8.24 */
#define CALIB_SLOPE_MAX ((int64_t)1 << (31 - FW_Q24_FRAC))

static int64_t abs64(int64_t v)
{
    return v < 0 ? -v : v;
}

/* The solver, with the rule a refusal breaks (FW_RULE_OK on success). */
static fw_rule_t calib_tilted(q24_t r_up, q24_t r_down, fw_bam_t phi, int32_t normal_gain_pn_per_v,
                              fw_calib_tilted_t *out)
{
    q30_t s2phi;
    int64_t num;
    int64_t den;
    int64_t x;
    int64_t one_m_4x2;
    int64_t sq;
    int64_t mu;
    fw_bam_t beta;
    fw_bam_t pb;
    q30_t spb;
    q30_t cpb;
    int64_t lat_den;
    int64_t lat;
    int64_t au = abs64(r_up);
    int64_t ad = abs64(r_down);
    if (normal_gain_pn_per_v <= 0) {
        return FW_RULE_FORCE_GAINS;
    }
    if (phi < fw_math_bam_from_mdeg(FW_CALIB_PHI_MIN_MDEG) || phi >= FW_BAM_QUARTER_TURN) {
        return FW_RULE_TILTED_SLOPE;
    }
    if (r_up <= 0) {
        return FW_RULE_TILTED_UPHILL;
    }
    /* |rho| > 1 + 2^-10 <=> (|r_u| - |r_d|) 2^10 > |r_d| */
    if ((au - ad) * ((int64_t)1 << CALIB_RHO_MARGIN_LOG2) <= ad) {
        return FW_RULE_TILTED_CONTRAST;
    }
    s2phi = fw_math_sin_q30(phi * 2u);
    num = ((int64_t)r_up - r_down) * s2phi;              /* 8.24 * 2.30 = x.54 */
    den = 2 * ((int64_t)r_up + r_down);                  /* 8.24 */
    x = fw_math_div_round_i64(num, den);                 /* 2.30 */
    if (x <= 0 || x > FW_Q30_ONE / 2) {
        return FW_RULE_TILTED_NO_ANGLE;
    }
    one_m_4x2 = FW_Q30_ONE - 4 * fw_math_rshift_round_i64(x * x, FW_Q30_FRAC);
    sq = fw_math_sqrt_q30((q30_t)(one_m_4x2 < 0 ? 0 : one_m_4x2));
    mu = fw_math_div_round_i64(2 * x * FW_Q30_ONE, FW_Q30_ONE + sq);
    beta = fw_math_atan2_bam((int32_t)mu, FW_Q30_ONE);
    pb = phi + beta;
    if (pb >= FW_BAM_QUARTER_TURN) {
        return FW_RULE_TILTED_NO_ANGLE;
    }
    fw_math_sincos_q30(pb, &spb, &cpb);
    lat_den = fw_math_rshift_round_i64((int64_t)cpb * r_up, FW_Q24_FRAC);   /* 2.30 */
    if (lat_den <= 0) {
        return FW_RULE_TILTED_NO_ANGLE;
    }
    lat = fw_math_div_round_i64((int64_t)normal_gain_pn_per_v * spb, lat_den);
    if (lat <= 0 || lat > INT32_MAX) {
        return FW_RULE_TILTED_NO_ANGLE;
    }
    out->mu = (q30_t)mu;
    out->mu_ppm = (int32_t)fw_math_div_round_i64(mu * FW_PPM_PER_ONE, FW_Q30_ONE);
    out->beta = beta;
    out->lateral_gain_pn_per_v = (int32_t)lat;
    return FW_RULE_OK;
}

fw_status_t fw_calib_tilted_solve(q24_t r_up, q24_t r_down, fw_bam_t phi, int32_t normal_gain_pn_per_v,
                                  fw_calib_tilted_t *out)
{
    if (out == NULL) {
        return FW_ERR_ARG;
    }
    return fw_rule_status(calib_tilted(r_up, r_down, phi, normal_gain_pn_per_v, out));
}

fw_rule_t fw_calib_tilted_rule(q24_t r_up, q24_t r_down, fw_bam_t phi, int32_t normal_gain_pn_per_v)
{
    fw_calib_tilted_t scratch;
    return calib_tilted(r_up, r_down, phi, normal_gain_pn_per_v, &scratch);
}

fw_status_t fw_calib_adhesion_pn(q24_t r_up, q23_t b_up_v, q24_t r_down, q23_t b_down_v,
                                 int32_t normal_gain_pn_per_v, int32_t *adhesion_pn, bool *sat)
{
    int64_t dr = (int64_t)r_up - r_down;                 /* 8.24 */
    int64_t db = (int64_t)b_up_v - b_down_v;             /* 9.23, < 2^32 */
    if (adhesion_pn == NULL || normal_gain_pn_per_v <= 0) {
        return FW_ERR_ARG;
    }
    if (dr == 0) {
        return FW_ERR_DOMAIN;
    }
    /* F = kn (db / 2^23) / (dr / 2^24) = 2 kn db / dr. |kn db| < 2^63, but
     * 2 kn db may not fit: divide first, then multiply by 2 (error <= 1 pN). */
    *adhesion_pn = fw_math_sat_i32(
        2 * (int64_t)fw_math_sat_i32(fw_math_div_round_i64((int64_t)normal_gain_pn_per_v * db, dr), sat), sat);
    return FW_OK;
}

fw_status_t fw_calib_lines_cn(const int32_t *depth_pm, const int32_t *offset_pm, int32_t n,
                              int32_t deflection_pm_per_v, int32_t *disp_n_pm_per_v, int32_t *residual_pm)
{
    int64_t sx = 0;
    int64_t sy = 0;
    int64_t sxx = 0;
    int64_t sxy = 0;
    int64_t dxx;
    int64_t dxy;
    int64_t slope;
    uint64_t se2 = 0;
    int32_t i;
    if (depth_pm == NULL || offset_pm == NULL || disp_n_pm_per_v == NULL || residual_pm == NULL
        || n < 2 || n > FW_CALIB_LINES_MAX || deflection_pm_per_v <= 0) {
        return FW_ERR_ARG;
    }
    for (i = 0; i < n; i++) {
        int64_t x = depth_pm[i];
        int64_t y = offset_pm[i];
        if (abs64(x) > FW_CALIB_LINES_RANGE_PM || abs64(y) > FW_CALIB_LINES_RANGE_PM) {
            return FW_ERR_ARG;
        }
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    dxx = n * sxx - sx * sx;       /* n^2 var(x) >= 0, < 2^60 */
    dxy = n * sxy - sx * sy;
    if (dxx <= 0) {
        return FW_ERR_DOMAIN;
    }
    while (dxx >= ((int64_t)1 << CALIB_DEN_BITS)) {
        dxx = fw_math_rshift_round_i64(dxx, 1);
        dxy = fw_math_rshift_round_i64(dxy, 1);
    }
    if (abs64(dxy) >= CALIB_SLOPE_MAX * dxx) {
        return FW_ERR_DOMAIN;
    }
    slope = fw_math_div_round_i64(dxy * FW_Q24_ONE, dxx);      /* 8.24, d per dz */
    for (i = 0; i < n; i++) {
        /* n e_i = (n y_i - S y) - slope (n x_i - S x); |.| < 2^31 * 2^31 */
        int64_t ny = (int64_t)n * offset_pm[i] - sy;
        int64_t nx = (int64_t)n * depth_pm[i] - sx;
        int64_t en = ny - fw_math_rshift_round_i64(slope * nx, FW_Q24_FRAC);
        int64_t e = fw_math_div_round_i64(en, n);
        se2 += (uint64_t)(e * e);
    }
    *disp_n_pm_per_v = fw_math_sat_i32(
        fw_math_rshift_round_i64(slope * deflection_pm_per_v, FW_Q24_FRAC), NULL);
    *residual_pm = (int32_t)fw_math_isqrt_round_u64(se2 / (uint64_t)n);
    return FW_OK;
}

fw_status_t fw_calib_disp_estimate(int32_t tip_height_nm, int32_t lever_length_nm,
                                   int32_t deflection_pm_per_v, int32_t *disp_pm_per_v)
{
    uint64_t num;
    uint64_t den;
    if (disp_pm_per_v == NULL || tip_height_nm <= 0 || lever_length_nm <= 0 || deflection_pm_per_v <= 0) {
        return FW_ERR_ARG;
    }
    if (tip_height_nm >= lever_length_nm) {
        return FW_ERR_DOMAIN;
    }
    num = 3u * (uint64_t)tip_height_nm * (uint64_t)deflection_pm_per_v;
    den = 2u * (uint64_t)lever_length_nm;
    *disp_pm_per_v = (int32_t)((num + den / 2u) / den);  /* < 1.5 K_n: fits */
    return FW_OK;
}

fw_status_t fw_calib_twist_estimate_q30(int32_t deflection_pm_per_v, int32_t lever_length_nm,
                                        q30_t *twist_rad_per_v)
{
    uint64_t num;
    uint64_t den;
    uint64_t k;
    if (twist_rad_per_v == NULL || deflection_pm_per_v <= 0 || lever_length_nm <= 0) {
        return FW_ERR_ARG;
    }
    num = 3u * (uint64_t)deflection_pm_per_v * ((uint64_t)1 << FW_Q30_FRAC);
    den = 2u * (uint64_t)FW_PM_PER_NM * (uint64_t)lever_length_nm;
    k = (num + den / 2u) / den;
    *twist_rad_per_v = (k > (uint64_t)INT32_MAX) ? INT32_MAX : (q30_t)k;
    return FW_OK;
}
