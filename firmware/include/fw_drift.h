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
 */
#ifndef FW_DRIFT_H
#define FW_DRIFT_H

#include "fw_types.h"
#include "fw_rules.h"
#include "fw_particles.h"
#include "fw_wire.h"
#include "fw_litho.h"

typedef struct {
    int32_t offset_pm[2];     /* accumulated drift since reset, frame A */
    int32_t max_step_pm;
    uint32_t rejected;        /* refused measurements (saturating) */
} fw_drift_t;

/* The correction limit of the card (physics.md section 10): a local scan
 * finds an object at most this far from its model, or it is not drift. */
#define FW_DRIFT_MAX_STEP_DEFAULT_PM 200000

/* FW_RULE_DRIFT_STEP for max_step_pm <= 0. */
fw_rule_t fw_drift_check(int32_t max_step_pm);
/* Validates with fw_drift_check (FW_ERR_ARG also for a NULL d). */
fw_status_t fw_drift_init(fw_drift_t *d, int32_t max_step_pm);
void fw_drift_reset(fw_drift_t *d);

/* Whether a scan within max_step_pm of a model: |scan - model| <= max step
 * (true, delta = scan - model) or not (false, delta 0). Pure: nothing
 * counted. FW_ERR_ARG-free: NULL pointers or max_step_pm <= 0 give false.
 * Scaling and overflow: 64-bit differences; squared norm compared in 64
 * bits after a per-axis bound (|d| <= max step < 2^31: d^2 < 2^62). */
bool fw_drift_within(const int32_t model_pm[2], const int32_t scan_pm[2], int32_t max_step_pm, int32_t delta_pm[2]);

/* delta = scanned - modelled (pm); accepted if |delta| <= max step (then
 * added to the offset). fw_drift_measure_within takes another limit for
 * one measurement (a landmark after a lever change may be far off). Scaling and overflow: 64-bit differences; squared
 * norm compared in 64 bits after a per-axis bound; offset saturated. */
fw_status_t fw_drift_measure(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2],
                             int32_t delta_pm[2]);
fw_status_t fw_drift_measure_within(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2],
                                    int32_t max_step_pm, int32_t delta_pm[2]);

/* Shift every object by delta (any pointer may be NULL; wires is an array
 * of n_wires). */
void fw_drift_apply(const int32_t delta_pm[2], fw_particles_t *particles, fw_wire_t *wires,
                    int32_t n_wires, fw_litho_t *litho);

#endif /* FW_DRIFT_H */
