/*
 * fw_calib.h - calibration solvers (physics.md sections 2 and 3).
 *
 * Tilted surface (section 2): loop slopes r_u, r_d (dS_l/dS_n, uphill and
 * downhill) on a surface of slope phi, scanned at 270 deg. With
 * rho = r_u / r_d, the closed form
 *   B  = 2 (rho + 1) / ((rho - 1) sin 2phi) = 2 (r_u + r_d) / ((r_u - r_d) sin 2phi)
 *   mu = 2 / (B + sqrt(B^2 - 4)) = 2x / (1 + sqrt(1 - 4x^2)),  x = 1/B
 *   beta = atan mu,  k_theta K_l / h = k_n K_n tan(phi + beta) / r_u
 * is evaluated through x = 1/B (no large numbers, no cancellation; r_d = 0,
 * i.e. rho infinite, is fine). Domain (FW_ERR_DOMAIN):
 *   phi must lie in [0.1 deg, 90 deg) (phi -> 0 is a flat surface: B -> 0/0
 *   or mu -> 0, no information; slopes below 0.1 deg are not measurable);
 *   r_u > 0 (the lateral gain is positive);
 *   |rho| > 1 + 2^-10, i.e. |r_u| - |r_d| > |r_d| / 1024: for rho within
 *     2^-10 of +-1 the two slopes are equal within 0.1 %, below what a
 *     friction loop resolves, and mu (about (rho - 1) / (2 sin 2phi)) or the
 *     0/0 at rho = -1 carries no information;
 *   x <= 1/2 (B >= 2: a real friction angle exists) and phi + beta < 90 deg.
 * r_d < 0 (phi < beta) is accepted.
 *
 * Adhesion (section 2): with adhesion both loop lines pass through
 * S_l = 0 at S_n = -F_adh / (k_n K_n); from the fitted lines
 * S_l = r_u S_n + b_u and S_l = r_d S_n + b_d,
 *   F_adh = k_n K_n (b_u - b_d) / (r_u - r_d).
 *
 * Inscribed lines (section 3): push depths dz_i (pm) give virtual outputs
 * S_n'_i = dz_i / K_n; the lines' lateral offsets d_i (pm) are fitted by
 * least squares d = C_n S_n' + b; the residual is the RMS of the fit
 * residuals (pm).
 *
 * Displacement estimate (section 3): C_n = C_l = 3 h K_n / (2 l).
 */
#ifndef FW_CALIB_H
#define FW_CALIB_H

#include "fw_types.h"
#include "fw_rules.h"

#define FW_CALIB_PHI_MIN_MDEG 100              /* smallest accepted surface slope */
#define FW_CALIB_LINES_MAX 64                 /* points of the C_n fit */
#define FW_CALIB_LINES_RANGE_PM ((int32_t)1 << 24)  /* |dz|, |d| limit: 16.7 um */

typedef struct {
    q30_t mu;                /* tip-substrate friction coefficient, 2.30 */
    int32_t mu_ppm;          /* same, parts per million */
    fw_bam_t beta;           /* atan mu */
    int32_t lateral_gain_pn_per_v;    /* k_theta K_l / h, pN/V */
} fw_calib_tilted_t;

/* Scaling and overflow: r in 8.24, sin 2phi in 2.30; x = (r_u - r_d) sin 2phi
 * / (2 (r_u + r_d)) as a 64-bit quotient in 2.30 (|r_u - r_d| sin < 2^62);
 * sqrt in 2.30; the lateral gain k_n K_n sin / (cos r_u) with a 64-bit
 * numerator (< 2^61); a gain beyond int32 is FW_ERR_DOMAIN.
 * Accuracy (test_calib sweep against the reference formulas): mu within
 * 6e-8 (64 LSB of 2.30), gain within 1 pN/V (rounding to integer pN/V). */
fw_status_t fw_calib_tilted_solve(q24_t r_up, q24_t r_down, fw_bam_t phi, int32_t normal_gain_pn_per_v,
                                  fw_calib_tilted_t *out);

/* The rule fw_calib_tilted_solve refuses the same arguments by:
 * FW_RULE_FORCE_GAINS (k_n K_n <= 0), FW_RULE_TILTED_SLOPE (phi outside
 * [0.1 deg, 90 deg)), FW_RULE_TILTED_UPHILL (r_u <= 0),
 * FW_RULE_TILTED_CONTRAST (|rho| <= 1 + 2^-10), FW_RULE_TILTED_NO_ANGLE (no
 * real friction angle: B < 2, phi + beta >= 90 deg, or a lateral gain past
 * int32); FW_RULE_OK where it solves. */
fw_rule_t fw_calib_tilted_rule(q24_t r_up, q24_t r_down, fw_bam_t phi, int32_t normal_gain_pn_per_v);

/* F_adh (pN) from the loop lines' slopes (8.24) and offsets (9.23 V).
 * FW_ERR_DOMAIN if r_u == r_d. Scaling and overflow: k_n K_n (b_u - b_d) in
 * 64 bits (< 2^63), divided by (r_u - r_d), then multiplied by 2 for the
 * 2^(24-23) format ratio (rounding error <= 1 pN); saturated to int32 (*sat). */
fw_status_t fw_calib_adhesion_pn(q24_t r_up, q23_t b_up_v, q24_t r_down, q23_t b_down_v,
                                 int32_t normal_gain_pn_per_v, int32_t *adhesion_pn, bool *sat);

/* C_n (pm/V) and the RMS residual (pm) from n points (2..64), |values| <=
 * FW_CALIB_LINES_RANGE_PM, K_n > 0 (pm/V). FW_ERR_DOMAIN if all depths
 * are equal or |slope d/dz| >= 128.
 * Scaling and overflow: sums n S(x^2) - (S x)^2 < 2^60; both sums are
 * halved together until the denominator is < 2^31, then the slope is a
 * 64-bit quotient in 8.24; C_n = K_n slope >> 24 (< 2^62), saturated. */
fw_status_t fw_calib_lines_cn(const int32_t *depth_pm, const int32_t *offset_pm, int32_t n,
                              int32_t deflection_pm_per_v, int32_t *disp_n_pm_per_v, int32_t *residual_pm);

/* The displacement constants' estimate (section 3: equal photodiode
 * sensitivity in both directions) C_n = C_l = 3 h K_n / (2 l), pm/V,
 * rounded; h, l > 0 (nm), K_n > 0 (pm/V) (FW_ERR_ARG), h < l
 * (FW_ERR_DOMAIN). The card uses it wherever no calibrated value is
 * configured (fw_card.h). Scaling and overflow: 3 h K_n < 3 * 2^62 in
 * uint64; the result < 1.5 K_n fits int32. */
fw_status_t fw_calib_disp_estimate(int32_t tip_height_nm, int32_t lever_length_nm,
                                   int32_t deflection_pm_per_v, int32_t *disp_pm_per_v);

/* The lever's twist per volt of S_l, K_l = 3 K_n / (2 l) rad/V (section
 * 3, the same estimate as C_l = h K_l), in 2.30, rounded, saturated at
 * INT32_MAX (2 rad/V: no lever). K_n > 0 (pm/V), l > 0 (nm), else
 * FW_ERR_ARG. Scaling and overflow: 3 K_n 2^30 < 1.5 2^62 in uint64. */
fw_status_t fw_calib_twist_estimate_q30(int32_t deflection_pm_per_v, int32_t lever_length_nm,
                                        q30_t *twist_rad_per_v);

#endif /* FW_CALIB_H */
