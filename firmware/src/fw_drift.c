/*
 * fw_drift.c - see fw_drift.h.
 */
#include "fw_drift.h"
#include "fw_math.h"

fw_rule_t fw_drift_check(int32_t max_step_pm)
{
    return (max_step_pm <= 0) ? FW_RULE_DRIFT_STEP : FW_RULE_OK;
}

fw_rule_t fw_drift_filter_check(int32_t filter, const fw_kalman_params_t *p, q16_t scan_var_nm2)
{
    if (filter == FW_DRIFT_FILTER_STEP) {
        return FW_RULE_OK;
    }
    if (filter != FW_DRIFT_FILTER_KALMAN || scan_var_nm2 < 0) {
        return FW_RULE_DRIFT_KALMAN;
    }
    return fw_kalman_check(p);
}

fw_status_t fw_drift_init(fw_drift_t *d, int32_t max_step_pm)
{
    if (d == NULL || fw_drift_check(max_step_pm) != FW_RULE_OK) {
        return FW_ERR_ARG;
    }
    d->max_step_pm = max_step_pm;
    d->filter = FW_DRIFT_FILTER_STEP;
    d->scan_var_nm2 = 0;
    fw_drift_reset(d);
    return FW_OK;
}

fw_status_t fw_drift_use_kalman(fw_drift_t *d, const fw_kalman_params_t *p, q16_t scan_var_nm2)
{
    if (d == NULL || fw_drift_filter_check(FW_DRIFT_FILTER_KALMAN, p, scan_var_nm2) != FW_RULE_OK) {
        return FW_ERR_ARG;
    }
    (void)fw_kalman_init(&d->kalman[0], p);
    (void)fw_kalman_init(&d->kalman[1], p);
    d->filter = FW_DRIFT_FILTER_KALMAN;
    d->scan_var_nm2 = scan_var_nm2;
    fw_drift_reset(d);
    return FW_OK;
}

void fw_drift_reset(fw_drift_t *d)
{
    d->offset_pm[0] = 0;
    d->offset_pm[1] = 0;
    d->rejected = 0;
    if (d->filter == FW_DRIFT_FILTER_KALMAN) {
        fw_kalman_reset(&d->kalman[0]);
        fw_kalman_reset(&d->kalman[1]);
    }
}

/* The Kalman filters' estimate becomes the offset; delta its change. */
static void drift_follow_kalman(fw_drift_t *d, int32_t delta_pm[2])
{
    int i;
    for (i = 0; i < 2; i++) {
        const int32_t now = fw_kalman_drift_pm(&d->kalman[i]);
        delta_pm[i] = fw_math_sat_i32((int64_t)now - d->offset_pm[i], NULL);
        d->offset_pm[i] = now;
    }
}

void fw_drift_predict(fw_drift_t *d, int32_t delta_pm[2])
{
    if (d == NULL || delta_pm == NULL) {
        return;
    }
    delta_pm[0] = 0;
    delta_pm[1] = 0;
    if (d->filter != FW_DRIFT_FILTER_KALMAN) {
        return;
    }
    fw_kalman_predict(&d->kalman[0]);
    fw_kalman_predict(&d->kalman[1]);
    drift_follow_kalman(d, delta_pm);
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

/* The gate both registrations pass: within the limit, or counted. */
static fw_status_t drift_gate(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2], int32_t max_step_pm,
                              int32_t delta_pm[2])
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
    return FW_OK;
}

fw_status_t fw_drift_measure_within(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2],
                                    int32_t max_step_pm, int32_t delta_pm[2])
{
    int i;
    fw_status_t s = drift_gate(d, model_pm, scan_pm, max_step_pm, delta_pm);
    if (s != FW_OK) {
        return s;
    }
    if (d->filter == FW_DRIFT_FILTER_KALMAN) {
        for (i = 0; i < 2; i++) {
            const int32_t z = fw_math_sat_i32((int64_t)d->offset_pm[i] + delta_pm[i], NULL);
            (void)fw_kalman_update(&d->kalman[i], z, d->scan_var_nm2);   /* the variance was checked at init */
        }
        drift_follow_kalman(d, delta_pm);
        return FW_OK;
    }
    d->offset_pm[0] = fw_math_sat_i32((int64_t)d->offset_pm[0] + delta_pm[0], NULL);
    d->offset_pm[1] = fw_math_sat_i32((int64_t)d->offset_pm[1] + delta_pm[1], NULL);
    return FW_OK;
}

fw_status_t fw_drift_jump_within(fw_drift_t *d, const int32_t model_pm[2], const int32_t scan_pm[2],
                                 int32_t max_step_pm, int32_t delta_pm[2])
{
    int i;
    fw_status_t s = drift_gate(d, model_pm, scan_pm, max_step_pm, delta_pm);
    if (s != FW_OK) {
        return s;
    }
    for (i = 0; i < 2; i++) {
        if (d->filter == FW_DRIFT_FILTER_KALMAN) {
            fw_kalman_shift_pm(&d->kalman[i], delta_pm[i]);
        }
        d->offset_pm[i] = fw_math_sat_i32((int64_t)d->offset_pm[i] + delta_pm[i], NULL);
    }
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
