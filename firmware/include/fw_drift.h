/*
 * fw_drift.h - drift correction from local scans (physics.md section 10).
 *
 * Before an operation a quick local scan around an object gives its true
 * position; the difference to the modelled position is the drift since the
 * last correction. It is accumulated and applied to every object model
 * (particles, wires, trenches) so the models stay registered to the sample.
 * A difference larger than max_step_pm is not drift (wrong object, or a
 * cantilever change needing a landmark re-registration): it is refused with
 * FW_ERR_DOMAIN and counted.
 *
 * The estimate (fw_drift_filter_t): FW_DRIFT_FILTER_STEP takes each
 * registration whole and holds it until the next; FW_DRIFT_FILTER_KALMAN
 * (fw_drift_use_kalman) runs fw_kalman on each axis: a registration is a
 * measurement of the drift (the offset so far plus the difference) with the
 * scan's variance, and between registrations the estimate moves on at the
 * drift's estimated velocity (fw_drift_predict, once a block). Either way
 * offset_pm is the drift the models carry, and every function that changes
 * it gives the change in delta_pm for the caller to move the models by
 * (fw_drift_apply).
 */
#ifndef FW_DRIFT_H
#define FW_DRIFT_H

#include "fw_types.h"
#include "fw_rules.h"
#include "fw_particles.h"
#include "fw_wire.h"
#include "fw_litho.h"
#include "fw_kalman.h"

typedef enum {
    FW_DRIFT_FILTER_STEP = 0,     /* each registration taken whole, held until the next */
    FW_DRIFT_FILTER_KALMAN = 1    /* fw_kalman per axis: constant velocity and a random walk */
} fw_drift_filter_t;

typedef struct {
    int32_t offset_pm[2];     /* the drift estimate the models carry, frame A */
    int32_t max_step_pm;
    uint32_t rejected;        /* refused measurements (saturating) */
    fw_drift_filter_t filter;
    fw_kalman_t kalman[2];    /* x, y, with FW_DRIFT_FILTER_KALMAN */
    q16_t scan_var_nm2;       /* a registration's variance, nm^2, 16.16 (FW_DRIFT_FILTER_KALMAN) */
} fw_drift_t;

/* The correction limit of the card (physics.md section 10): a local scan
 * finds an object at most this far from its model, or it is not drift. */
#define FW_DRIFT_MAX_STEP_DEFAULT_PM 200000

/* FW_RULE_DRIFT_STEP for max_step_pm <= 0. */
fw_rule_t fw_drift_check(int32_t max_step_pm);
/* FW_RULE_DRIFT_KALMAN for a filter outside fw_drift_filter_t, or, with
 * FW_DRIFT_FILTER_KALMAN, fw_kalman_check's rule or a negative scan
 * variance. */
fw_rule_t fw_drift_filter_check(int32_t filter, const fw_kalman_params_t *p, q16_t scan_var_nm2);
/* Validates with fw_drift_check (FW_ERR_ARG also for a NULL d); the step
 * filter. */
fw_status_t fw_drift_init(fw_drift_t *d, int32_t max_step_pm);
/* The Kalman filter from now on (fw_drift_filter_check: FW_ERR_ARG, nothing
 * changed), reset. */
fw_status_t fw_drift_use_kalman(fw_drift_t *d, const fw_kalman_params_t *p, q16_t scan_var_nm2);
/* No drift, counters zero (the filter's state too; the filter stays). */
void fw_drift_reset(fw_drift_t *d);

/* One block passes: with the Kalman filter the estimate moves on
 * (fw_kalman_predict, fw_kalman_drift_pm) and delta_pm is its change; with
 * the step filter delta_pm is 0. Scaling and overflow: the change in int64,
 * saturated to int32 (the offset is the filter's, within int32). */
void fw_drift_predict(fw_drift_t *d, int32_t delta_pm[2]);

/* Whether a scan within max_step_pm of a model: |scan - model| <= max step
 * (true, delta = scan - model) or not (false, delta 0). Pure: nothing
 * counted. FW_ERR_ARG-free: NULL pointers or max_step_pm <= 0 give false.
 * Scaling and overflow: 64-bit differences; squared norm compared in 64
 * bits after a per-axis bound (|d| <= max step < 2^31: d^2 < 2^62). */
bool fw_drift_within(const int32_t model_pm[2], const int32_t scan_pm[2], int32_t max_step_pm, int32_t delta_pm[2]);

/* delta = scanned - modelled (pm); accepted if |delta| <= max step. The
 * step filter adds it to the offset; the Kalman filter takes offset +
 * delta as a measurement of the drift with the scan's variance
 * (fw_kalman_update) and delta becomes the change of its estimate.
 * fw_drift_measure_within takes another limit for one measurement.
 * Scaling and overflow: 64-bit differences; squared norm compared in 64
 * bits after a per-axis bound; offset saturated; fw_kalman_update's. */
fw_status_t fw_drift_measure(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2],
                             int32_t delta_pm[2]);
fw_status_t fw_drift_measure_within(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2],
                                    int32_t max_step_pm, int32_t delta_pm[2]);
/* A jump, not drift (a landmark after a lever change): as
 * fw_drift_measure_within, but the difference is added whole to the
 * offset with either filter (the Kalman filter's drift shifts,
 * fw_kalman_shift_pm; its velocity stays). */
fw_status_t fw_drift_jump_within(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2],
                                 int32_t max_step_pm, int32_t delta_pm[2]);

/* Shift every object by delta (any pointer may be NULL; wires is an array
 * of n_wires). */
void fw_drift_apply(const int32_t delta_pm[2], fw_particles_t *particles, fw_wire_t *wires,
                    int32_t n_wires, fw_litho_t *litho);

#endif /* FW_DRIFT_H */
