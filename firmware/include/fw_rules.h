/*
 * fw_rules.h - the rules the firmware's init functions check, named.
 *
 * Every module that validates a configuration does it in one place, a
 * check function fw_<module>_check(...) returning the first rule the
 * arguments break (FW_RULE_OK when none); its init calls it and returns
 * fw_rule_status(rule). fw_card_init reports the rule itself, so a host
 * can say which configuration value the card refuses without restating
 * the rule (host/card_setup.cpp names the scene keys that feed
 * each rule).
 *
 * Rules are positive, FW_RULE_OK is zero; fw_rule_status maps each to the
 * status its init returns (FW_ERR_ARG for a value outside its documented
 * set, FW_ERR_DOMAIN where the model has no answer, FW_ERR_CAPACITY for
 * caller-owned storage that is too small).
 */
#ifndef FW_RULES_H
#define FW_RULES_H

#include "fw_types.h"

typedef enum {
    FW_RULE_OK = 0,
    FW_RULE_NULL_POINTER,          /* a required pointer is NULL */
    FW_RULE_ADC_BITS,              /* ADC word: 8 to 16 bits (fw_acq) */
    FW_RULE_ADC_FILTER,            /* ADC moving average: 2^0 .. 2^4 samples (fw_acq) */
    FW_RULE_FORCE_GAINS,           /* k_n K_n and k_theta K_l / h > 0 pN/V (fw_force) */
    FW_RULE_LEVER_POSITIVE,        /* tip height h and lever length l > 0 nm (fw_force) */
    FW_RULE_TIP_SHORTER_THAN_LEVER,/* h < l, i.e. 2h/l < 2 (fw_force, eq. 1c) */
    FW_RULE_MU_RANGE,              /* tip-substrate mu in [0, 1] (fw_force) */
    FW_RULE_ADHESION,              /* tip-substrate adhesion >= 0 pN (fw_force) */
    FW_RULE_MU_2H_OVER_L,          /* mu 2h/l <= 1/2 (fw_force, friction fallback) */
    FW_RULE_DEFLECTION_GAIN,       /* K_n > 0 pm/V (fw_board, virtual S_n) */
    FW_RULE_THETA_MIN_DISP,        /* theta window's minimum displacement >= 0 pm (fw_theta) */
    FW_RULE_DISP_NEGATIVE,         /* C_n, C_l >= 0 pm/V (fw_comp) */
    FW_RULE_DISP_RANGE,            /* C_n, C_l <= 2^22 pm/V (fw_comp) */
    FW_RULE_JOYSTICK_RANGE,        /* joystick half range >= 0 pm and kappa >= 0 (fw_comp) */
    FW_RULE_TIP_RADIUS,            /* tip radius in [0, 2^30] pm (fw_particles) */
    FW_RULE_PARTICLE,              /* particle radius, threshold, contact margin, substrate mu (fw_particles, fw_card) */
    FW_RULE_PARTICLE_CAPACITY,     /* more particles than the card's storage (fw_particles) */
    FW_RULE_WIRE,                  /* wire length in (0, 2^30] pm, diameter > 0 pm (fw_wire) */
    FW_RULE_WIRE_FRICTION,         /* wire friction per length >= 0, wire mu in [0, 2) (fw_wire) */
    FW_RULE_WIRE_CAPACITY,         /* more wires than the card's storage (fw_card) */
    FW_RULE_LITHO,                 /* litho threshold >= 0 pN, depth gain >= 0, step > 0 pm (fw_litho) */
    FW_RULE_TIP_HALF_ANGLE,        /* tip cone half angle in (0, 60) deg (fw_litho, fw_wire) */
    FW_RULE_LITHO_CAPACITY,        /* no trench storage although lithography is on (fw_litho) */
    FW_RULE_DRIFT_STEP,            /* drift and landmark correction limits > 0 pm (fw_drift) */
    FW_RULE_LANDMARKS,             /* the landmark list: a count >= 0, and a list when > 0 (fw_card) */
    FW_RULE_HAPTIC,                /* haptic gain >= 0 uN/pN, force limit >= 0 uN (fw_card) */
    FW_RULE_WORD_BITS,             /* the signal chain's word: 16 or 32 bits (fw_card) */
    FW_RULE_WORD16_RANGE,          /* the 16-bit chain's domain (fw_board16.h) */
    FW_RULE_TILTED_SLOPE,          /* the calibration surface's slope in [0.1, 90) deg (fw_calib) */
    FW_RULE_TILTED_UPHILL,         /* the uphill friction-loop slope r_u > 0 (fw_calib) */
    FW_RULE_TILTED_CONTRAST,       /* |r_u / r_d| > 1 + 2^-10 (fw_calib) */
    FW_RULE_TILTED_NO_ANGLE,       /* the slopes give a real friction angle (fw_calib) */
    FW_RULE_INTERLOCK_NORMAL,      /* the interlock's normal limit in (0, k_n K_n 10 V) pN (fw_guard) */
    FW_RULE_INTERLOCK_LATERAL,     /* the interlock's lateral limit in (0, k_theta K_l / h 10 V) pN (fw_guard) */
    FW_RULE_HYST,                  /* the scanner's hysteresis model's domain (fw_hyst.h) */
    FW_RULE_CREEP,                 /* the scanner's creep law's domain (fw_creep.h) */
    FW_RULE_DRIFT_KALMAN,          /* the drift filter's domain (fw_kalman.h) */
    FW_RULE_COUNT
} fw_rule_t;

/* The rule in words, with its limits in the firmware's units; a constant
 * string, never NULL ("unknown rule" outside the enum). */
const char *fw_rule_text(fw_rule_t rule);

/* The status an init returns for a broken rule: FW_OK for FW_RULE_OK. */
fw_status_t fw_rule_status(fw_rule_t rule);

#endif /* FW_RULES_H */
