/*
 * bench_ref.c - see bench_ref.h.
 */
#include <math.h>
#include "bench_ref.h"

#define REF_PI 3.14159265358979323846
#define REF_FS_V 10.0
#define REF_SIN_LO (4096.0 / 32768.0)   /* FW_FORCE_SIN_LO_Q15 */
#define REF_SIN_HI (8192.0 / 32768.0)   /* FW_FORCE_SIN_HI_Q15 */

void bench_ref_init(bench_ref_t *r, const fw_board_config_t *cfg, int adc_bits)
{
    double alpha = (cfg->scan_angle_mdeg - 270000) * 1e-3 * REF_PI / 180.0;
    r->adc_bits = adc_bits;
    r->normal_gain_pn_per_v = cfg->normal_gain_pn_per_v;
    r->lateral_gain_pn_per_v = cfg->lateral_gain_pn_per_v;
    r->two_h_over_l = 2.0 * cfg->tip_height_nm / cfg->lever_length_nm;
    r->mu = cfg->mu_ppm * 1e-6;
    r->adhesion_pn = cfg->adhesion_pn;
    r->disp_n_pm_per_v = cfg->disp_n_pm_per_v;
    r->disp_l_pm_per_v = cfg->disp_l_pm_per_v;
    r->cos_a = cos(alpha);
    r->sin_a = sin(alpha);
    r->min_disp_pm = (cfg->theta_min_disp_pm == 0) ? FW_THETA_MIN_DISP_DEFAULT_PM
                                                     : cfg->theta_min_disp_pm;
    bench_ref_reset(r);
}

void bench_ref_reset(bench_ref_t *r)
{
    int i;
    for (i = 0; i < FW_THETA_WINDOW; i++) {
        r->x_pm[i] = 0.0;
        r->y_pm[i] = 0.0;
    }
    r->pos = 0;
    r->fill = 0;
    r->cos_theta = 0.0;
    r->sin_theta = 1.0;
}

static double ref_volts(const bench_ref_t *r, int32_t uv)
{
    double v = uv * 1e-6;
    double half;
    double code;
    if (r->adc_bits == 0) {
        return v;
    }
    half = (double)(1L << (r->adc_bits - 1));
    code = round(v / REF_FS_V * half);   /* exact halves cannot occur (fw_acq.c) */
    if (code > half - 1.0) {
        code = half - 1.0;
    }
    if (code < -half) {
        code = -half;
    }
    return code * REF_FS_V / half;
}

void bench_ref_step(bench_ref_t *r, const fw_sample_in_t *in, double force_a_pn[3])
{
    double sn = ref_volts(r, in->sn_uv);
    double sl = ref_volts(r, in->sl_uv);
    double ox = r->disp_n_pm_per_v * sn;
    double oy = r->disp_l_pm_per_v * sl;
    double ax = in->piezo_pm[0] + r->cos_a * ox - r->sin_a * oy;
    double ay = in->piezo_pm[1] + r->sin_a * ox + r->cos_a * oy;
    int oldest;
    double dx;
    double dy;
    double cx;
    double cy;
    double len;
    double c;
    double s;
    double as;
    double fx = 0.0;
    double fy;
    double n;
    double fz;

    /* theta: same window bookkeeping as fw_theta_step */
    r->x_pm[r->pos] = ax;
    r->y_pm[r->pos] = ay;
    if (r->fill < FW_THETA_WINDOW) {
        r->fill++;
        oldest = 0;
    } else {
        oldest = (r->pos + 1) % FW_THETA_WINDOW;
    }
    dx = ax - r->x_pm[oldest];
    dy = ay - r->y_pm[oldest];
    r->pos = (r->pos + 1) % FW_THETA_WINDOW;
    cx = r->cos_a * dx + r->sin_a * dy;
    cy = -r->sin_a * dx + r->cos_a * dy;
    len = sqrt(cx * cx + cy * cy);
    if (len >= r->min_disp_pm && len > 0.0) {
        r->cos_theta = cx / len;
        r->sin_theta = cy / len;
    }
    c = r->cos_theta;
    s = r->sin_theta;

    /* eq. 1a-1c with the fallback and blend of fw_force.h */
    fy = r->lateral_gain_pn_per_v * sl;
    n = r->normal_gain_pn_per_v * sn;
    as = fabs(s);
    if (as >= REF_SIN_LO) {
        fx = fy * c / s;
    }
    if (as < REF_SIN_HI) {
        double fb = -r->mu * c * (n + r->adhesion_pn) / (1.0 - r->mu * c * r->two_h_over_l);
        double w = (as - REF_SIN_LO) / (REF_SIN_HI - REF_SIN_LO);
        fx = (as < REF_SIN_LO) ? fb : w * fx + (1.0 - w) * fb;
    }
    fz = n - r->two_h_over_l * fx;

    /* eq. 3 */
    force_a_pn[0] = r->cos_a * fx - r->sin_a * fy;
    force_a_pn[1] = r->sin_a * fx + r->cos_a * fy;
    force_a_pn[2] = fz;
}
