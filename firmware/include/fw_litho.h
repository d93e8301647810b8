/*
 * fw_litho.h - nanolithography trenches recorded along the tip path
 * (physics.md section 9), in caller-owned storage.
 *
 * While the load F_z (force of the sample on the tip, pN, positive when
 * pressing) exceeds the threshold, the tip inscribes a trench:
 *   depth = g (F_z - F_th)          (linear law; g calibrated, pm/pN, 16.16)
 *   width = 2 depth tan gamma       (gamma: tip cone half angle)
 * A point is appended when a stroke starts (load crosses the threshold) and
 * then whenever the apex has moved at least min_step_pm (horizontal) from
 * the last recorded point; consecutive points of a stroke form the trench's
 * polyline. When the storage is full further points are dropped: the step
 * returns FW_ERR_CAPACITY, the sticky overflow flag latches and the drop
 * counter counts them (saturating); a dropped point still sets where the
 * next one is due, so the counter counts points, not samples.
 */
#ifndef FW_LITHO_H
#define FW_LITHO_H

#include "fw_types.h"
#include "fw_rules.h"

#define FW_LITHO_STROKE_START (1u << 0)   /* fw_trench_point_t.flags: first point of a stroke */

typedef struct {
    int32_t x_pm;
    int32_t y_pm;
    int32_t depth_pm;
    int32_t width_pm;
    uint32_t flags;
} fw_trench_point_t;

typedef struct {
    fw_trench_point_t *pts;   /* caller-owned */
    int32_t capacity;
    int32_t count;
    int32_t threshold_pn;
    q16_t depth_pm_per_pn;
    q30_t tan_gamma;          /* 2.30, gamma < 60 deg so tan < 2 */
    int32_t min_step_pm;
    bool in_stroke;
    int32_t last_pm[2];       /* the last point recorded or dropped (the step test's origin) */
    bool overflow;            /* sticky */
    uint32_t dropped;         /* points dropped for lack of capacity */
} fw_litho_t;

/* The first rule broken: threshold < 0, gain < 0 or min step <= 0
 * (FW_RULE_LITHO); gamma outside (0, 60 deg) (mdeg, FW_RULE_TIP_HALF_ANGLE). */
fw_rule_t fw_litho_check(int32_t threshold_pn, q16_t depth_pm_per_pn, int32_t gamma_mdeg, int32_t min_step_pm);

/* Validates with fw_litho_check (FW_ERR_ARG also for a NULL pointer or
 * capacity <= 0). Zeroes the storage. */
fw_status_t fw_litho_init(fw_litho_t *l, fw_trench_point_t *storage, int32_t capacity,
                          int32_t threshold_pn, q16_t depth_pm_per_pn, int32_t gamma_mdeg,
                          int32_t min_step_pm);

/* Forget all points and the sticky state; keep the parameters. */
void fw_litho_reset(fw_litho_t *l);

/* One sample: apex (frame A, pm) and load F_z (pN).
 * Scaling and overflow: (F_z - F_th) in 64 bits times the 16.16 gain,
 * >> 16 rounded, saturated; width = 2 depth tan gamma (2.30) saturated;
 * step test on 64-bit squared distances. */
fw_status_t fw_litho_step(fw_litho_t *l, const int32_t tip_pm[3], int32_t load_pn);

/* Shift every point by (dx, dy) pm (drift), saturated. */
void fw_litho_shift(fw_litho_t *l, int32_t dx_pm, int32_t dy_pm);

#endif /* FW_LITHO_H */
