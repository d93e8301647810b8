/*
 * fw_wire.c - see fw_wire.h.
 */
#include "fw_wire.h"
#include "fw_math.h"

#define WIRE_Q60_ONE ((int64_t)1 << (2 * FW_Q30_FRAC))

fw_status_t fw_wire_static_point(int32_t length_pm, int32_t l_pm, fw_wire_static_t *out)
{
    int64_t two_l_minus_L;
    int64_t u;
    int64_t au;
    q30_t sq;
    int64_t half_len;   /* sqrt(Q) = L sqrt(u^2 + 1) / 2 */
    if (out == NULL || length_pm <= 0 || length_pm > FW_WIRE_LENGTH_MAX_PM) {
        return FW_ERR_ARG;
    }
    if (l_pm < 0 || l_pm > length_pm) {
        return FW_ERR_DOMAIN;
    }
    two_l_minus_L = 2 * (int64_t)l_pm - length_pm;
    u = fw_math_div_round_i64(two_l_minus_L * FW_Q30_ONE, length_pm);
    au = u < 0 ? -u : u;
    /* sqrt(1 + u^2) in 2.30 from the 4.60 argument (<= 2^61) */
    sq = (q30_t)fw_math_isqrt_round_u64((uint64_t)(WIRE_Q60_ONE + u * u));
    half_len = fw_math_rshift_round_i64((int64_t)length_pm * sq, FW_Q30_FRAC + 1);
    out->u = (q30_t)u;
    out->k = (q30_t)fw_math_div_round_i64(WIRE_Q60_ONE, (int64_t)sq + au);
    out->lever_pm = (int32_t)half_len;
    if (two_l_minus_L < 0) {
        out->regime = FW_WIRE_ROTATE_NEAR_B;
        out->s_defined = true;
        out->s_pm = fw_math_sat_i32((int64_t)l_pm + half_len, NULL);
        if (out->s_pm > length_pm) {
            out->s_pm = length_pm;
        }
    } else if (two_l_minus_L > 0) {
        out->regime = FW_WIRE_ROTATE_NEAR_A;
        out->s_defined = true;
        out->s_pm = fw_math_sat_i32((int64_t)l_pm - half_len, NULL);
        if (out->s_pm < 0) {
            out->s_pm = 0;
        }
    } else {
        out->regime = FW_WIRE_TRANSLATE;
        out->s_defined = false;
        out->s_pm = 0;
    }
    return FW_OK;
}

int32_t fw_wire_push_threshold_pn(q30_t k, int32_t friction_fl_pn, bool *sat)
{
    return fw_math_sat_i32(fw_math_rshift_round_i64((int64_t)k * friction_fl_pn, FW_Q30_FRAC), sat);
}

fw_rule_t fw_wire_check(int32_t length_pm, int32_t diameter_pm)
{
    return (length_pm <= 0 || length_pm > FW_WIRE_LENGTH_MAX_PM || diameter_pm <= 0 || length_pm < diameter_pm)
               ? FW_RULE_WIRE
               : FW_RULE_OK;
}

fw_status_t fw_wire_init(fw_wire_t *w, int32_t x_pm, int32_t y_pm, fw_bam_t psi,
                         int32_t length_pm, int32_t diameter_pm)
{
    fw_rule_t rule = fw_wire_check(length_pm, diameter_pm);
    if (w == NULL) {
        return FW_ERR_ARG;
    }
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    w->x_pm = x_pm;
    w->y_pm = y_pm;
    w->psi = psi;
    w->length_pm = length_pm;
    w->diameter_pm = diameter_pm;
    w->flags = 0;
    return FW_OK;
}

fw_status_t fw_wire_init_ends(fw_wire_t *w, const int32_t a_pm[2], const int32_t b_pm[2], int32_t diameter_pm)
{
    int64_t dx;
    int64_t dy;
    int shift = 0;
    int64_t len;
    if (w == NULL || a_pm == NULL || b_pm == NULL) {
        return FW_ERR_ARG;
    }
    dx = (int64_t)b_pm[0] - a_pm[0];
    dy = (int64_t)b_pm[1] - a_pm[1];
    while (dx > INT32_MAX || dx < INT32_MIN || dy > INT32_MAX || dy < INT32_MIN) {
        dx = fw_math_asr_i64(dx, 1);
        dy = fw_math_asr_i64(dy, 1);
        shift++;
    }
    len = (int64_t)fw_math_isqrt_round_u64((uint64_t)(dx * dx) + (uint64_t)(dy * dy)) << shift;
    if (len > FW_WIRE_LENGTH_MAX_PM) {
        return fw_rule_status(FW_RULE_WIRE);
    }
    return fw_wire_init(w, (int32_t)fw_math_asr_i64((int64_t)a_pm[0] + b_pm[0], 1),
                        (int32_t)fw_math_asr_i64((int64_t)a_pm[1] + b_pm[1], 1),
                        fw_math_atan2_bam((int32_t)dy, (int32_t)dx), (int32_t)len, diameter_pm);
}

void fw_wire_ends_pm(const fw_wire_t *w, int32_t a_pm[2], int32_t b_pm[2])
{
    q30_t s;
    q30_t c;
    int64_t hx;
    int64_t hy;
    fw_math_sincos_q30(w->psi, &s, &c);
    /* half the length along the axis: |L c| / 2 < 2^59 */
    hx = fw_math_rshift_round_i64((int64_t)w->length_pm * c, FW_Q30_FRAC + 1);
    hy = fw_math_rshift_round_i64((int64_t)w->length_pm * s, FW_Q30_FRAC + 1);
    a_pm[0] = fw_math_sat_i32((int64_t)w->x_pm - hx, NULL);
    a_pm[1] = fw_math_sat_i32((int64_t)w->y_pm - hy, NULL);
    b_pm[0] = fw_math_sat_i32((int64_t)w->x_pm + hx, NULL);
    b_pm[1] = fw_math_sat_i32((int64_t)w->y_pm + hy, NULL);
}

fw_status_t fw_wire_push(fw_wire_t *w, int32_t l_pm, int32_t dn_pm, fw_wire_static_t *info)
{
    fw_wire_static_t st;
    fw_status_t status;
    int64_t au;
    int64_t wt;          /* blend weight, 2.30 */
    int64_t dpsi = 0;    /* radians, 2.30 */
    int64_t factor;      /* centre step / dn, 2.30 */
    int64_t step;
    q30_t s;
    q30_t c;
    bool sat = false;
    if (w == NULL) {
        return FW_ERR_ARG;
    }
    status = fw_wire_static_point(w->length_pm, l_pm, &st);
    if (status != FW_OK) {
        return status;
    }
    if (dn_pm > w->length_pm / 4 || dn_pm < -(w->length_pm / 4)) {
        return FW_ERR_DOMAIN;
    }
    if (info != NULL) {
        *info = st;
    }
    au = st.u < 0 ? -(int64_t)st.u : st.u;
    wt = au * (FW_Q30_ONE / FW_WIRE_BLEND_U);
    if (wt > FW_Q30_ONE) {
        wt = FW_Q30_ONE;
    }
    factor = FW_Q30_ONE;
    if (st.s_defined && wt > 0) {
        /* l - s = sign(u) sqrt(Q), |l - s| >= L/2 > 0 */
        int64_t l_minus_s = (st.u < 0) ? -(int64_t)st.lever_pm : (int64_t)st.lever_pm;
        int64_t ratio = fw_math_div_round_i64(((int64_t)w->length_pm - 2 * (int64_t)st.s_pm) * FW_Q30_ONE,
                                              2 * ((int64_t)l_pm - st.s_pm));
        dpsi = fw_math_div_round_i64(wt * dn_pm, l_minus_s);
        factor = fw_math_rshift_round_i64(wt * ratio, FW_Q30_FRAC) + (FW_Q30_ONE - wt);
    }
    step = fw_math_rshift_round_i64(factor * dn_pm, FW_Q30_FRAC);
    fw_math_sincos_q30(w->psi, &s, &c);
    /* normal n = (-sin psi, cos psi) */
    w->x_pm = fw_math_sat_i32((int64_t)w->x_pm - fw_math_rshift_round_i64(step * s, FW_Q30_FRAC), &sat);
    w->y_pm = fw_math_sat_i32((int64_t)w->y_pm + fw_math_rshift_round_i64(step * c, FW_Q30_FRAC), &sat);
    w->psi += fw_math_bam_from_rad_q30((q30_t)dpsi);
    if (sat) {
        w->flags |= FW_WIRE_SAT_POS;
    }
    return FW_OK;
}

fw_status_t fw_wire_contact(const fw_wire_t *w, const int32_t tip_pm[2], int32_t reach_pm, bool *touch,
                            int32_t *l_pm, int32_t *dn_pm)
{
    q30_t s;
    q30_t c;
    int64_t dx;
    int64_t dy;
    int64_t along;
    int64_t normal;
    int64_t l;
    bool sat = false;
    if (w == NULL || tip_pm == NULL || touch == NULL || l_pm == NULL || dn_pm == NULL || reach_pm < 0) {
        return FW_ERR_ARG;
    }
    fw_math_sincos_q30(w->psi, &s, &c);
    dx = (int64_t)tip_pm[0] - w->x_pm;
    dy = (int64_t)tip_pm[1] - w->y_pm;
    /* |dx|, |dy| < 2^32 and |s|, |c| <= 2^30: each product < 2^62, sum < 2^63 */
    along = fw_math_rshift_round_i64(dx * c + dy * s, FW_Q30_FRAC);
    normal = fw_math_rshift_round_i64(dy * c - dx * s, FW_Q30_FRAC);
    l = along + w->length_pm / 2;
    *l_pm = fw_math_sat_i32(l, &sat);
    *dn_pm = fw_math_sat_i32(normal <= 0 ? normal + reach_pm : normal - reach_pm, &sat);
    *touch = l >= 0 && l <= w->length_pm && normal > -(int64_t)reach_pm && normal < reach_pm;
    return FW_OK;
}

void fw_wire_shift(fw_wire_t *w, int32_t dx_pm, int32_t dy_pm)
{
    bool sat = false;
    if (w == NULL) {
        return;
    }
    w->x_pm = fw_math_sat_i32((int64_t)w->x_pm + dx_pm, &sat);
    w->y_pm = fw_math_sat_i32((int64_t)w->y_pm + dy_pm, &sat);
    if (sat) {
        w->flags |= FW_WIRE_SAT_POS;
    }
}

fw_status_t fw_wire_squeeze_solve(fw_bam_t psi, q30_t k, q30_t mu, int32_t friction_fl_pn,
                                  int32_t adhesion_ts_pn, fw_squeeze_t *out)
{
    int64_t kmu;
    uint64_t norm;
    q30_t sm;
    int64_t den;
    int64_t fr;
    bool sat = false;
    if (out == NULL || psi >= FW_BAM_QUARTER_TURN || k <= 0 || k > FW_Q30_ONE || mu < 0
        || friction_fl_pn < 0 || adhesion_ts_pn < 0) {
        return FW_ERR_ARG;
    }
    kmu = fw_math_rshift_round_i64((int64_t)k * mu, FW_Q30_FRAC);      /* < 2^31 */
    out->psi_max = fw_math_atan2_bam(FW_Q30_ONE, (int32_t)kmu);
    out->flags = 0;
    if (psi >= out->psi_max) {
        out->f_r_pn = INT32_MAX;
        out->push_pn = INT32_MAX;
        out->df_pn = INT32_MAX;
        out->flags = FW_FLAG_SQUEEZE;
        return FW_ERR_DOMAIN;
    }
    sm = fw_math_sin_q30(out->psi_max - psi);
    norm = fw_math_isqrt_round_u64((uint64_t)(WIRE_Q60_ONE + kmu * kmu));  /* 2.30, < 2^31 */
    den = fw_math_rshift_round_i64((int64_t)norm * sm, FW_Q30_FRAC);
    if (den <= 0) {
        fr = INT64_MAX;
    } else {
        fr = fw_math_div_round_i64((int64_t)k * friction_fl_pn, den);
    }
    out->f_r_pn = fw_math_sat_i32(fr, &sat);
    out->push_pn = fw_math_sat_i32(
        fw_math_rshift_round_i64((int64_t)out->f_r_pn * fw_math_cos_q30(psi), FW_Q30_FRAC), &sat);
    out->df_pn = fw_math_sat_i32(
        fw_math_rshift_round_i64((int64_t)out->f_r_pn * fw_math_sin_q30(psi), FW_Q30_FRAC)
        - adhesion_ts_pn, &sat);
    if (sat) {
        out->flags |= FW_FLAG_SAT_FORCE;
    }
    return FW_OK;
}

#define WIRE_GAMMA_MAX_MDEG 60000

fw_rule_t fw_wire_check_tip(int32_t tip_radius_pm, int32_t tip_half_angle_mdeg, int32_t friction_pn_per_um,
                            int32_t mu_ppm, int32_t adhesion_ts_pn)
{
    if (friction_pn_per_um < 0 || mu_ppm < 0 || mu_ppm > FW_WIRE_MU_MAX_PPM) {
        return FW_RULE_WIRE_FRICTION;
    }
    if (tip_radius_pm < 0 || tip_radius_pm > FW_WIRE_LENGTH_MAX_PM) {
        return FW_RULE_TIP_RADIUS;
    }
    if (tip_half_angle_mdeg <= 0 || tip_half_angle_mdeg >= WIRE_GAMMA_MAX_MDEG) {
        return FW_RULE_TIP_HALF_ANGLE;
    }
    if (adhesion_ts_pn < 0) {
        return FW_RULE_ADHESION;
    }
    return FW_RULE_OK;
}

fw_status_t fw_wire_tip_init(fw_wire_tip_t *tip, int32_t tip_radius_pm, int32_t tip_half_angle_mdeg,
                             int32_t friction_pn_per_um, int32_t mu_ppm, int32_t adhesion_ts_pn)
{
    fw_rule_t rule = fw_wire_check_tip(tip_radius_pm, tip_half_angle_mdeg, friction_pn_per_um, mu_ppm,
                                       adhesion_ts_pn);
    if (tip == NULL) {
        return FW_ERR_ARG;
    }
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    tip->tip_radius_pm = tip_radius_pm;
    tip->tip_half_angle = fw_math_bam_from_mdeg(tip_half_angle_mdeg);
    tip->friction_pn_per_um = friction_pn_per_um;
    tip->mu = (q30_t)fw_math_div_round_i64((int64_t)mu_ppm * FW_Q30_ONE, FW_PPM_PER_ONE);
    tip->adhesion_ts_pn = adhesion_ts_pn;
    tip->down_force = false;
    return FW_OK;
}

int32_t fw_wire_friction_pn(const fw_wire_tip_t *tip, const fw_wire_t *w)
{
    return fw_math_sat_i32(fw_math_div_round_i64((int64_t)tip->friction_pn_per_um * w->length_pm,
                                                 (int64_t)FW_PM_PER_NM * FW_PM_PER_NM), NULL);
}

/* psi = gamma + |theta_t| as a binary angle, |theta_t| clamped below 90
 * deg (2.30 radians to fw_bam_t: fw_math_bam_from_rad_q30). */
static fw_bam_t wire_contact_angle(const fw_wire_tip_t *tip, q30_t twist_rad)
{
    /* pi / 2 in 2.30, rounded down */
    const int64_t quarter_rad = 1686629713;
    int64_t t = twist_rad < 0 ? -(int64_t)twist_rad : twist_rad;
    if (t > quarter_rad) {
        t = quarter_rad;
    }
    return tip->tip_half_angle + fw_math_bam_from_rad_q30((q30_t)t);
}

fw_status_t fw_wire_update(fw_wire_t *w, const fw_wire_tip_t *tip, const int32_t apex_pm[2], int64_t excess_pn,
                           q30_t twist_rad)
{
    bool touch;
    bool sat = false;
    int32_t l;
    int32_t dn;
    int32_t fl;
    int32_t max_step;
    fw_wire_static_t st;
    fw_squeeze_t sq;
    fw_bam_t psi;
    int steps;
    if (w == NULL || tip == NULL || apex_pm == NULL) {
        return FW_ERR_ARG;
    }
    w->flags &= ~(FW_WIRE_PUSHED | FW_WIRE_SQUEEZED);
    if (fw_wire_contact(w, apex_pm, tip->tip_radius_pm + w->diameter_pm / 2, &touch, &l, &dn) != FW_OK || !touch) {
        return FW_OK;
    }
    if (fw_wire_static_point(w->length_pm, l, &st) != FW_OK) {
        return FW_OK;
    }
    fl = fw_wire_friction_pn(tip, w);
    if (excess_pn <= (int64_t)(fw_wire_push_threshold_pn(st.k, fl, &sat) >> 1)) {
        return FW_OK;
    }
    if (tip->down_force) {
        fw_status_t sqs = FW_ERR_DOMAIN;
        psi = wire_contact_angle(tip, twist_rad);
        if (psi < FW_BAM_QUARTER_TURN) {
            sqs = fw_wire_squeeze_solve(psi, st.k, tip->mu, fl, tip->adhesion_ts_pn, &sq);
        }
        if (sqs == FW_ERR_DOMAIN) {
            w->flags |= FW_WIRE_SQUEEZED;
            return FW_OK;
        }
        /* FW_ERR_ARG cannot happen (tip and k validated): then k f L stands */
        if (sqs == FW_OK && excess_pn <= (int64_t)(sq.push_pn >> 1)) {
            return FW_OK;
        }
    }
    max_step = w->length_pm / 4;
    if (max_step < 1) {
        max_step = 1;   /* rods of under 4 pm (shorter ones are refused: L >= d > 0) */
    }
    for (steps = 0; dn != 0 && steps < FW_WIRE_PUSH_STEPS_MAX; steps++) {
        int32_t step = (dn > max_step) ? max_step : ((dn < -max_step) ? -max_step : dn);
        if (fw_wire_push(w, l, step, NULL) != FW_OK) {
            break;
        }
        dn -= step;
    }
    w->flags |= FW_WIRE_PUSHED;
    return FW_OK;
}
