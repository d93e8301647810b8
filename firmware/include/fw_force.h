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
 */
#ifndef FW_FORCE_H
#define FW_FORCE_H

#include "fw_types.h"

#define FW_FORCE_SIN_LO_Q15 ((q15_t)4096)   /* 1/8 in 1.15 */
#define FW_FORCE_SIN_HI_Q15 ((q15_t)8192)   /* 1/4 in 1.15 */

typedef struct {
    int32_t kn_pn_per_v;     /* k_n K_n, pN/V */
    int32_t lat_pn_per_v;    /* k_theta K_l / h, pN/V */
    q30_t two_h_over_l;      /* 2h/l, 2.30 */
    q30_t mu;                /* tip-substrate friction coefficient, 2.30 */
    int32_t adhesion_pn;     /* F_adh, pN */
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

/* Rotate a frame-C vector into frame A by R(alpha) (eq. 3); z unchanged.
 * cos/sin alpha in 2.30. Saturates (*sat). */
void fw_force_rotate_pn(const int32_t v_c[3], q30_t cos_a, q30_t sin_a,
                        int32_t v_a[3], bool *sat);

/* ---- direction of motion ------------------------------------------------
 * theta is estimated from the apex positions (frame A, pm) of the last
 * FW_THETA_WINDOW samples: d = p_now - p_(now - WINDOW + 1), rotated into
 * frame C by R(-alpha). If |d| < min_disp_pm the direction is unknown and the
 * last known direction is held; before any is known, theta = 90 deg
 * (motion across the lever, F_x = 0) and FW_FLAG_THETA_UNKNOWN is set. */
#define FW_THETA_WINDOW 16
#define FW_THETA_MIN_DISP_DEFAULT_PM 1000

typedef struct {
    int32_t x_pm[FW_THETA_WINDOW];
    int32_t y_pm[FW_THETA_WINDOW];
    int32_t pos;
    int32_t fill;
    int32_t min_disp_pm;
    q15_t cos_theta;        /* latest direction, frame C, 1.15 */
    q15_t sin_theta;
    bool known;
} fw_theta_t;

fw_status_t fw_theta_init(fw_theta_t *t, int32_t min_disp_pm);
void fw_theta_reset(fw_theta_t *t);

/* Push the apex (frame A) and update the direction. Sets
 * FW_FLAG_THETA_UNKNOWN in *flags while no direction is known.
 * Scaling and overflow: displacement in 64 bits, clamped to int32 before
 * the rotation (a move of 2 mm per window is already out of range). */
void fw_theta_step(fw_theta_t *t, const int32_t apex_pm[2], q30_t cos_a, q30_t sin_a,
                   uint32_t *flags);

#endif /* FW_FORCE_H */
