/*
 * fw_drift.c - see fw_drift.h.
 */
#include "fw_drift.h"
#include "fw_math.h"

fw_rule_t fw_drift_check(int32_t max_step_pm)
{
    return (max_step_pm <= 0) ? FW_RULE_DRIFT_STEP : FW_RULE_OK;
}

fw_status_t fw_drift_init(fw_drift_t *d, int32_t max_step_pm)
{
    if (d == NULL || fw_drift_check(max_step_pm) != FW_RULE_OK) {
        return FW_ERR_ARG;
    }
    d->max_step_pm = max_step_pm;
    fw_drift_reset(d);
    return FW_OK;
}

void fw_drift_reset(fw_drift_t *d)
{
    d->offset_pm[0] = 0;
    d->offset_pm[1] = 0;
    d->rejected = 0;
}

fw_status_t fw_drift_measure(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2],
                             int32_t delta_pm[2])
{
    if (d == NULL) {
        return FW_ERR_ARG;
    }
    return fw_drift_measure_within(d, model_pm, scan_pm, d->max_step_pm, delta_pm);
}

bool fw_drift_within(const int32_t model_pm[2], const int32_t scan_pm[2], int32_t max_step_pm, int32_t delta_pm[2])
{
    int64_t dx;
    int64_t dy;
    int64_t m;
    if (model_pm == NULL || scan_pm == NULL || delta_pm == NULL) {
        return false;
    }
    delta_pm[0] = 0;
    delta_pm[1] = 0;
    if (max_step_pm <= 0) {
        return false;
    }
    dx = (int64_t)scan_pm[0] - model_pm[0];
    dy = (int64_t)scan_pm[1] - model_pm[1];
    m = max_step_pm;
    if (dx > m || -dx > m || dy > m || -dy > m || dx * dx + dy * dy > m * m) {
        return false;
    }
    delta_pm[0] = (int32_t)dx;
    delta_pm[1] = (int32_t)dy;
    return true;
}

fw_status_t fw_drift_measure_within(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2],
                                    int32_t max_step_pm, int32_t delta_pm[2])
{
    if (d == NULL || model_pm == NULL || scan_pm == NULL || delta_pm == NULL || max_step_pm <= 0) {
        return FW_ERR_ARG;
    }
    if (!fw_drift_within(model_pm, scan_pm, max_step_pm, delta_pm)) {
        if (d->rejected != UINT32_MAX) {
            d->rejected++;
        }
        return FW_ERR_DOMAIN;
    }
    d->offset_pm[0] = fw_math_sat_i32((int64_t)d->offset_pm[0] + delta_pm[0], NULL);
    d->offset_pm[1] = fw_math_sat_i32((int64_t)d->offset_pm[1] + delta_pm[1], NULL);
    return FW_OK;
}

void fw_drift_apply(const int32_t delta_pm[2], fw_particles_t *particles, fw_wire_t *wires,
                    int32_t n_wires, fw_litho_t *litho)
{
    int32_t i;
    if (delta_pm == NULL) {
        return;
    }
    fw_particles_shift(particles, delta_pm[0], delta_pm[1]);
    for (i = 0; wires != NULL && i < n_wires; i++) {
        fw_wire_shift(&wires[i], delta_pm[0], delta_pm[1]);
    }
    fw_litho_shift(litho, delta_pm[0], delta_pm[1]);
}
