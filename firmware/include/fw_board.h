/*
 * fw_board.h - one acquisition card's worth of firmware: per sample,
 * acquisition -> force -> compensation (physics.md sections 1, 3, 4).
 *
 * Frames: C (cantilever) and A (scanner), alpha = scan_angle - 270 deg,
 * R(alpha) rotates C into A (fw_force.h). Force outputs are the force BY THE
 * SAMPLE ON THE TIP, frame A, pN. Positions are frame A, pm, z up.
 *
 * Per sample (fw_board_step):
 *  1. S_n, S_l quantised (fw_acq.h), filtered, baseline subtracted.
 *  2. If S_n is saturated and an unsaturated reference exists, the virtual
 *     S_n' = S_n,ref + (z_ref - z_piezo) / K_n is used (FW_FLAG_VIRTUAL_SN).
 *  3. Apex estimate p_tip = p_piezo + R(alpha) [+C_n S_n, C_l S_l, 0] (sign: fw_comp.h),
 *     formed as one matrix M = R(alpha) diag(C_n, C_l) on (S_n, S_l).
 *  4. theta from the apex motion over the last FW_THETA_WINDOW (16) samples
 *     (fw_theta.h); direction unknown below cfg.theta_min_disp_pm (default
 *     1000 pm = 1 nm) of displacement over the window (last direction held;
 *     90 deg before any motion, FW_FLAG_THETA_UNKNOWN). Kept as the frame-C
 *     vector theta.dir_x, theta.dir_y; the unit vector is not formed per
 *     sample.
 *  5. Force in C (eq. 1a-1c, blend near sin theta = 0) from that vector
 *     (fw_force.h, the one solver), rotated into A (eq. 3).
 * The per-sample functions of the modules are inline: on the fast path a
 * sample makes no call at all (fallback and blend included).
 * fw_board_step_block runs a whole buffer (the ADC's DMA block) with the
 * path chosen once; the card (fw_card.h) uses it.
 * Flags of the sample are returned in out->flags; sticky flags and counters
 * accumulate in the instance until fw_board_reset.
 *
 * Two paths, one result. fw_board_step_checked saturates every step and
 * serves every configuration. fw_board_init also selects a fast path when
 * the configuration proves that no force or offset term can overflow:
 * no ADC filter, k_n K_n and k_theta K_l / h <= 2^18 pN/V
 * (FW_FORCE_FAST_GAIN_MAX_PN_PER_V), F_adh <= 2^26 pN
 * (FW_FORCE_FAST_ADHESION_MAX_PN), C_n, C_l <= 2^21 pm/V
 * (FW_COMP_FAST_C_MAX_PM_PER_V); with alpha = 0 exactly (scan angle 270 deg,
 * the default) it skips the rotations: M's cross terms, the direction into
 * frame C and the force into frame A (FW_BOARD_PATH_FAST_ALIGNED).
 * On the fast path the offsets and force terms are formed straight from
 * the ADC codes (fw_acq_gain, exact), with the gains kept as a cache in
 * the instance (fw_board_gains_t). Each call has a fixed cost (the
 * arguments, the run's state in and out; ./afm bench firmware -b 1 shows
 * it): the firmware is meant to be given blocks (the card's DMA block).
 * fw_board_step takes the fast path for a sample when both inputs lie in
 * the ADC's fast range (fw_acq_in_fast_range: no saturation, no top-code
 * clamp; then |S| <= 20 V after the baseline) and a sample has been stepped
 * since the reset; otherwise the checked one. The fast path omits only the
 * clamps that the bounds make impossible and finishes every direction
 * (cot zone, friction fallback, blend) with no call; an apex past int32 or
 * a theta window over 16 nm hands the sample to fw_board_step_checked.
 * Both paths, one sample at a time or in blocks, give bit-identical
 * outputs, flags, counters and state (tests/firmware/test_board_fast.c compares
 * them over 10^6 samples, in blocks of 1 to 64).
 *
 * Pointers: fw_board_step and fw_board_step_block test their pointers
 * once per call (FW_ERR_ARG, nothing changed); fw_board_step is a block of
 * one sample (one copy of the fast path in the image).
 *
 * Configuration zero values: the fields after kappa_q16 are optional and 0
 * selects the documented default.
 */
#ifndef FW_BOARD_H
#define FW_BOARD_H

#include "fw_types.h"
#include "fw_acq.h"
#include "fw_force.h"
#include "fw_comp.h"
#include "fw_theta.h"
#include "fw_rules.h"

typedef struct {
    int32_t adc_bits;               /* 8..16 (fw_acq) */
    int32_t normal_gain_pn_per_v;   /* k_n K_n: normal force per volt of S_n, pN/V */
    int32_t lateral_gain_pn_per_v;  /* k_theta K_l / h: lateral force per volt of S_l, pN/V */
    int32_t deflection_pm_per_v;    /* K_n: lever deflection per volt of S_n, pm/V */
    int32_t tip_height_nm;          /* h */
    int32_t lever_length_nm;        /* l */
    int32_t disp_n_pm_per_v;        /* C_n: apex displacement per volt of S_n, pm/V (0: none) */
    int32_t disp_l_pm_per_v;        /* C_l: apex displacement per volt of S_l, pm/V (0: none) */
    int32_t scan_angle_mdeg;     /* scan angle in millidegrees; alpha = angle - 270000 */
    int32_t mu_ppm;              /* tip-substrate friction coefficient x 1e6 */
    int32_t adhesion_pn;         /* tip-substrate adhesion F_adh, pN */
    int32_t scan_center_pm[2];   /* joystick 0 maps here, AFM frame */
    int32_t scan_half_range_pm;  /* r_scan/2 */
    int32_t kappa_q16;           /* kappa, 16.16 */
    /* optional, 0 = default */
    int32_t filter_log2;         /* ADC moving average 2^n samples, 0..4 (0 = off) */
    int32_t theta_min_disp_pm;   /* 0 = FW_THETA_MIN_DISP_DEFAULT_PM */
} fw_board_config_t;

typedef struct { int32_t sn_uv; int32_t sl_uv; int32_t piezo_pm[3]; } fw_sample_in_t;   /* volts at card input in microvolts; piezo xyz in AFM frame, pm */
typedef struct { int32_t force_pn[3]; int32_t tip_pm[3]; int32_t sn_code; int32_t sl_code; uint32_t flags; } fw_sample_out_t; /* force on the tip, AFM frame, pN; compensated apex, AFM frame, pm */

/* Which per-sample path fw_board_step takes (fw_board_init selects). */
typedef enum {
    FW_BOARD_PATH_CHECKED = 0,      /* every step saturated (any configuration) */
    FW_BOARD_PATH_FAST = 1,         /* bounds proven at init, no clamps */
    FW_BOARD_PATH_FAST_ALIGNED = 2  /* as FAST, alpha = 0: no rotations */
} fw_board_path_t;

/* The fast path's gains on the ADC codes (fw_acq_gain): the bending
 * offset in frame A (fw_comp_code_gains_t), and the force terms N, F_y
 * (pN, 8 fraction bits). A cache: formed from the
 * configuration and the baselines baseline_n_v, baseline_l_v; the fast
 * path forms it again when either baseline differs (however it was set)
 * or valid is false (init, reset). */
typedef struct {
    fw_comp_code_gains_t offset;
    fw_acq_gain_t n8;
    fw_acq_gain_t fy8;
    q23_t baseline_n_v;
    q23_t baseline_l_v;
    bool valid;
} fw_board_gains_t;

typedef struct {
    fw_board_config_t cfg;
    fw_acq_t acq_sn;
    fw_acq_t acq_sl;
    fw_force_t force;
    fw_comp_t comp;
    fw_theta_t theta;
    q30_t cos_a;                 /* cos alpha, 2.30 */
    q30_t sin_a;                 /* sin alpha, 2.30 */
    q23_t sn_v;                  /* latest S_n used (virtual if saturated), 9.23 V */
    q23_t sl_v;                  /* latest S_l, 9.23 V */
    int32_t z_pm;                /* latest piezo z, pm */
    q23_t sn_ref_v;              /* last unsaturated S_n, kept at the first saturated sample */
    int32_t z_ref_pm;            /* piezo z at that sample */
    bool have_ref;               /* an unsaturated sample since reset */
    bool ref_live;               /* the latest sample was unsaturated: it is the reference
                                    (sn_v, z_pm), copied to sn_ref_v, z_ref_pm when S_n saturates */
    bool stepped;                /* a sample has been stepped since reset */
    fw_board_path_t path_cfg;    /* the path the configuration allows (init) */
    int32_t fast_lo_uv;          /* fw_board_step's fast test, both channels: */
    uint32_t fast_span_uv;       /*   the ADC's fast range, span 0 while the checked path is due */
    uint32_t sticky_flags;       /* OR of every sample's flags since reset */
    uint32_t sat_force_count;    /* samples with a clamped force (saturating) */
    fw_board_gains_t gains;      /* the fast path's gains on the codes (a cache) */
} fw_board_t;

/* The first rule cfg breaks, in the order acquisition (fw_acq_check),
 * force (fw_force_check), K_n > 0 (FW_RULE_DEFLECTION_GAIN), compensation
 * (fw_comp_check), direction (fw_theta_check); FW_RULE_NULL_POINTER for a
 * NULL cfg. */
fw_rule_t fw_board_check(const fw_board_config_t *cfg);
/* Validates with fw_board_check (its rule's status; FW_ERR_ARG for a NULL
 * b). */
fw_status_t fw_board_init(fw_board_t *b, const fw_board_config_t *cfg);

/* The lever's axis x_C in frame A for a scan angle: (cos alpha, sin alpha),
 * alpha = scan angle - 270 deg (physics.md section 0), in 2.30. The host's
 * planner keeps its pushes off it. Scaling and overflow: fw_math_sincos_q30
 * of the angle in binary angle units; any scan angle (taken mod 360 deg). */
void fw_board_lever_axis_q30(int32_t scan_angle_mdeg, q30_t axis[2]);
void        fw_board_reset(fw_board_t *b);
/* One sample: fw_board_step_block with n = 1. FW_OK, FW_ERR_ARG for a
 * NULL pointer. */
fw_status_t fw_board_step(fw_board_t *b, const fw_sample_in_t *in, fw_sample_out_t *out);
/* n samples from a buffer (the ADC's DMA block): the same outputs, flags,
 * counters and state as n calls of fw_board_step, with the path chosen
 * once per block and no call per sample on the fast path. out[i] belongs
 * to in[i]; the buffers must not overlap. FW_ERR_ARG (nothing done) for a
 * NULL b, or a NULL in or out with n > 0; n = 0 is FW_OK and changes
 * nothing. */
fw_status_t fw_board_step_block(fw_board_t *b, const fw_sample_in_t *in, fw_sample_out_t *out, size_t n);
/* The checked path of fw_board_step for any sample and configuration (the
 * reference the fast path is tested against); FW_ERR_ARG for a NULL
 * pointer. */
fw_status_t fw_board_step_checked(fw_board_t *b, const fw_sample_in_t *in, fw_sample_out_t *out);
fw_status_t fw_board_piezo_cmd(const fw_board_t *b, const int32_t joy_q15[2], int32_t piezo_cmd_pm[2]);

/* Records the latest filtered S_n, S_l as the zero-force baseline (call while
 * the tip is free). FW_ERR_STATE before the first sample. */
fw_status_t fw_board_record_baseline(fw_board_t *b);

/* Sticky flags / saturation counters since the last reset. */
uint32_t fw_board_sticky_flags(const fw_board_t *b);
uint32_t fw_board_sat_count(const fw_board_t *b, uint32_t flag);

#endif /* FW_BOARD_H */
