/*
 * fw_guard.c - see fw_guard.h.
 */
#include "fw_guard.h"

/* The ADC's range in whole volts: full scale = gain x this. */
#define GUARD_FS_V (FW_ACQ_FS_UV / FW_UV_PER_V)
#define GUARD_PERCENT_OF_ONE 100

int64_t fw_guard_full_scale_pn(int32_t gain_pn_per_v)
{
    return (int64_t)gain_pn_per_v * GUARD_FS_V;
}

int32_t fw_guard_default_limit_pn(int32_t gain_pn_per_v)
{
    if (gain_pn_per_v <= 0) {
        return 0;
    }
    return fw_math_sat_i32(fw_guard_full_scale_pn(gain_pn_per_v) * FW_GUARD_DEFAULT_PERCENT / GUARD_PERCENT_OF_ONE,
                           NULL);
}

/* A limit in (0, full scale). */
static bool guard_limit_ok(int32_t limit_pn, int32_t gain_pn_per_v)
{
    return limit_pn > 0 && (int64_t)limit_pn < fw_guard_full_scale_pn(gain_pn_per_v);
}

fw_rule_t fw_guard_check(int32_t normal_limit_pn, int32_t lateral_limit_pn, int32_t normal_gain_pn_per_v,
                         int32_t lateral_gain_pn_per_v)
{
    if (!guard_limit_ok(normal_limit_pn, normal_gain_pn_per_v)) {
        return FW_RULE_INTERLOCK_NORMAL;
    }
    if (!guard_limit_ok(lateral_limit_pn, lateral_gain_pn_per_v)) {
        return FW_RULE_INTERLOCK_LATERAL;
    }
    return FW_RULE_OK;
}

fw_status_t fw_guard_init(fw_guard_t *g, int32_t normal_limit_pn, int32_t lateral_limit_pn,
                          int32_t normal_gain_pn_per_v, int32_t lateral_gain_pn_per_v)
{
    fw_rule_t rule;
    if (g == NULL) {
        return FW_ERR_ARG;
    }
    rule = fw_guard_check(normal_limit_pn, lateral_limit_pn, normal_gain_pn_per_v, lateral_gain_pn_per_v);
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    g->normal_limit_pn = normal_limit_pn;
    g->lateral_limit_pn = lateral_limit_pn;
    g->lateral_gain_pn_per_v = lateral_gain_pn_per_v;
    g->lateral_over_q23 = (2 * (int64_t)lateral_limit_pn + 1) * ((int64_t)1 << (FW_Q23_FRAC - 1));
    fw_guard_reset(g);
    return FW_OK;
}

void fw_guard_reset(fw_guard_t *g)
{
    g->latched = false;
    g->causes = 0u;
    g->release_load_pn = 0;
    g->trip_xy_pm[0] = 0;
    g->trip_xy_pm[1] = 0;
    g->trips = 0u;
}

int32_t fw_guard_release_load_pn(int32_t normal_limit_pn, int32_t load_at_trip_pn)
{
    int64_t base = (load_at_trip_pn < normal_limit_pn) ? load_at_trip_pn : normal_limit_pn;
    return fw_math_sat_i32(base - (int64_t)(normal_limit_pn >> FW_GUARD_HYST_SHIFT), NULL);
}

bool fw_guard_moved(const int32_t from_pm[2], const int32_t to_pm[2], int32_t dist_pm)
{
    int64_t dx = (int64_t)to_pm[0] - from_pm[0];
    int64_t dy = (int64_t)to_pm[1] - from_pm[1];
    int64_t d = dist_pm;
    if (dx >= d || -dx >= d || dy >= d || -dy >= d) {
        return true;
    }
    return dx * dx + dy * dy >= d * d;
}

fw_guard_state_t fw_guard_step(fw_guard_t *g, uint32_t causes, const fw_guard_pose_t *pose)
{
    bool moved;
    if (g == NULL || pose == NULL) {
        return FW_GUARD_ARMED;
    }
    causes &= FW_GUARD_CAUSE_NORMAL | FW_GUARD_CAUSE_LATERAL;
    if (causes != 0u) {
        g->causes |= causes;   /* 0 while armed (reset, release) */
        g->latched = true;
        g->release_load_pn = fw_guard_release_load_pn(g->normal_limit_pn, pose->load_pn);
        g->trip_xy_pm[0] = pose->xy_pm[0];
        g->trip_xy_pm[1] = pose->xy_pm[1];
        if (g->trips != UINT32_MAX) {
            g->trips++;
        }
        return FW_GUARD_TRIPPED;
    }
    if (!g->latched) {
        return FW_GUARD_ARMED;
    }
    moved = g->causes == FW_GUARD_CAUSE_LATERAL && fw_guard_moved(g->trip_xy_pm, pose->xy_pm, FW_GUARD_RELEASE_MOVE_PM);
    if (!pose->engaged || pose->load_pn < g->release_load_pn || moved) {
        g->latched = false;
        g->causes = 0u;
        return FW_GUARD_RELEASED;
    }
    return FW_GUARD_HOLDING;
}
