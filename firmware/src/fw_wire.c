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
    out->k_q16 = (int32_t)fw_math_rshift_round_i64(out->k, FW_Q30_FRAC - 16);
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

/* ---- the static point with held pieces ---------------------------------- */

#define HELD_ONE ((int32_t)1 << 16)                 /* L in 16.16 fractions of L */
#define HELD_PIECE (HELD_ONE / FW_WIRE_PIECES)      /* 2^11 */

/* Twice the moment about l of [a, b] (fractions of L, 16.16):
 * (b - a)(a + b - 2l), |.| < 2^17 * 2^18. */
static int64_t held_moment(int32_t a, int32_t b, int32_t l)
{
    return (int64_t)(b - a) * ((int64_t)a + b - 2 * (int64_t)l);
}

static int64_t held_weight(uint32_t held, int32_t hold_q16, int k)
{
    return ((held >> k) & 1u) != 0u ? hold_q16 : HELD_ONE;
}

/* G(s) = sum_k w_k int_piece sign(x - s)(x - l) dx, doubled (16.16 units):
 * each term < 2^26 * 2^28, the sum < 2^59. */
static int64_t held_torque(uint32_t held, int32_t hold_q16, int32_t l, int32_t s)
{
    int64_t g = 0;
    int k;
    for (k = 0; k < FW_WIRE_PIECES; k++) {
        int32_t a = k * HELD_PIECE;
        int32_t b = a + HELD_PIECE;
        int64_t w = held_weight(held, hold_q16, k);
        if (s <= a) {
            g += w * held_moment(a, b, l);
        } else if (s >= b) {
            g -= w * held_moment(a, b, l);
        } else {
            g += w * (held_moment(s, b, l) - held_moment(a, s, l));
        }
    }
    return g;
}

/* Net friction of a rotation about s: sum_k w_k (length past s - length
 * before s), 16.16 weight times 16.16 length: |.| < 2^26 * 2^16. */
static int64_t held_net(uint32_t held, int32_t hold_q16, int32_t s)
{
    int64_t f = 0;
    int k;
    for (k = 0; k < FW_WIRE_PIECES; k++) {
        int32_t a = k * HELD_PIECE;
        int32_t b = a + HELD_PIECE;
        int32_t lo = s < a ? a : (s > b ? b : s);
        f += held_weight(held, hold_q16, k) * ((int64_t)(b - lo) - (lo - a));
    }
    return f;
}

/* The u a uniform rod would have with its static point d (16.16 of L)
 * from its nearest end, signed as its regime: from d = (1 + v - sqrt(1 +
 * v^2)) / 2, v = |u|: v = (1/m - m) / 2 with m = 1 - 2d, capped at 1 (d >=
 * 1 - 1/sqrt2, an end push). fw_wire_push's blend then weighs the turn by
 * how close S has come to the rod's end, as it does on a uniform rod.
 * Scaling and overflow: m in 2.30 (0 < m <= 2^30); 2^60 / m < 2^61. */
static q30_t held_blend_u(int32_t d_q16, bool near_a)
{
    int64_t m = FW_Q30_ONE - ((int64_t)d_q16 << (FW_Q30_FRAC - 15));
    int64_t v;
    if (m <= 0) {
        v = FW_Q30_ONE;
    } else {
        v = (fw_math_div_round_i64((int64_t)1 << 60, m) - m) / 2;
        if (v > FW_Q30_ONE) {
            v = FW_Q30_ONE;
        }
        if (v < 0) {
            v = 0;
        }
    }
    return (q30_t)(near_a ? v : -v);
}

fw_status_t fw_wire_static_point_held(int32_t length_pm, int32_t l_pm, uint32_t held, int32_t hold_q16,
                                      fw_wire_static_t *out)
{
    int32_t lq;
    int32_t lo;
    int32_t hi;
    int32_t sq;
    int64_t g0;
    int64_t total = 0;
    int64_t k16;
    int64_t lever;
    int k;
    if (held == 0u || hold_q16 == FW_WIRE_HOLD_ONE_Q16) {
        return fw_wire_static_point(length_pm, l_pm, out);
    }
    if (out == NULL || length_pm <= 0 || length_pm > FW_WIRE_LENGTH_MAX_PM || hold_q16 < FW_WIRE_HOLD_ONE_Q16
        || hold_q16 > FW_WIRE_HOLD_MAX_Q16) {
        return FW_ERR_ARG;
    }
    if (l_pm < 0 || l_pm > length_pm) {
        return FW_ERR_DOMAIN;
    }
    lq = (int32_t)fw_math_div_round_i64((int64_t)l_pm * HELD_ONE, length_pm);
    g0 = held_torque(held, hold_q16, lq, 0);
    for (k = 0; k < FW_WIRE_PIECES; k++) {
        total += held_weight(held, hold_q16, k) * HELD_PIECE;
    }
    out->u = 0;
    if (g0 == 0) {
        out->regime = FW_WIRE_TRANSLATE;
        out->s_defined = false;
        out->s_pm = 0;
        sq = lq;
    } else {
        /* G rises up to l and falls after it: the root lies below l when
         * G(0) < 0, above it when G(L) = -G(0) < 0. Invariant: G(lo) < 0
         * exactly when the root lies below l (lo on the rising side below
         * the root, or the falling side above l before it). */
        bool below = g0 < 0;
        lo = below ? 0 : lq;
        hi = below ? lq : HELD_ONE;
        while (hi - lo > 1) {
            int32_t mid = lo + (hi - lo) / 2;
            int64_t g = held_torque(held, hold_q16, lq, mid);
            if ((g < 0) == below) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        {
            int64_t glo = held_torque(held, hold_q16, lq, lo);
            int64_t ghi = held_torque(held, hold_q16, lq, hi);
            sq = ((glo < 0 ? -glo : glo) <= (ghi < 0 ? -ghi : ghi)) ? lo : hi;
        }
        out->regime = below ? FW_WIRE_ROTATE_NEAR_A : FW_WIRE_ROTATE_NEAR_B;
        out->s_defined = true;
        out->s_pm = (int32_t)fw_math_div_round_i64((int64_t)sq * length_pm, HELD_ONE);
        out->u = held_blend_u(sq < HELD_ONE - sq ? sq : HELD_ONE - sq, below);
    }
    /* translation: the whole friction W; a rotation: the net about s */
    k16 = out->s_defined ? held_net(held, hold_q16, sq) : total;
    k16 = fw_math_rshift_round_i64(k16 < 0 ? -k16 : k16, 16);
    out->k_q16 = (int32_t)(k16 > FW_WIRE_HOLD_MAX_Q16 ? FW_WIRE_HOLD_MAX_Q16 : k16);
    out->k = (k16 >= HELD_ONE) ? FW_Q30_ONE : (q30_t)(k16 << (FW_Q30_FRAC - 16));
    lever = (int64_t)l_pm - out->s_pm;
    lever = lever < 0 ? -lever : lever;
    if (!out->s_defined || lever < length_pm / 16) {
        lever = length_pm / 16;
    }
    out->lever_pm = (int32_t)lever;
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
    w->held = 0;
    w->hold_q16 = FW_WIRE_HOLD_ONE_Q16;
    w->hold_at_pm[0] = 0;
    w->hold_at_pm[1] = 0;
    w->hold_at_psi = 0;
    w->hold_points = -1;
    w->axis_z_pm = diameter_pm / 2;
    w->judge = FW_WIRE_JUDGE_NONE;
    w->touching = false;
    w->z_ref_valid = false;
    w->z_ref_pm = 0;
    w->snap_pm[0] = x_pm;
    w->snap_pm[1] = y_pm;
    w->snap_psi = psi;
    w->contact_moved_pm = 0;
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

/* The move of a push by dn at l about the static point st (solved for that
 * l and the rod's held pieces): fw_wire_push's body, which fw_wire_update's
 * steps share without solving st again. dn already checked against L/4
 * and the lever (wire_step_ok). */
static void wire_move(fw_wire_t *w, int32_t dn_pm, const fw_wire_static_t *st)
{
    int64_t au;
    int64_t wt;          /* blend weight, 2.30 */
    int64_t dpsi = 0;    /* radians, 2.30 */
    int64_t factor;      /* centre step / dn, 2.30 */
    int64_t step;
    q30_t s;
    q30_t c;
    bool sat = false;
    au = st->u < 0 ? -(int64_t)st->u : st->u;
    wt = au * (FW_Q30_ONE / FW_WIRE_BLEND_U);
    if (wt > FW_Q30_ONE) {
        wt = FW_Q30_ONE;
    }
    factor = FW_Q30_ONE;
    if (st->s_defined && wt > 0) {
        /* l - s: -lever when S lies beyond l towards B; |l - s| >= L/2 on
         * a uniform rod (sqrt(Q)), >= L/16 on a held one (clamped) */
        int64_t l_minus_s = (st->regime == FW_WIRE_ROTATE_NEAR_B) ? -(int64_t)st->lever_pm : (int64_t)st->lever_pm;
        int64_t ratio = fw_math_div_round_i64(((int64_t)w->length_pm - 2 * (int64_t)st->s_pm) * FW_Q30_ONE,
                                              2 * l_minus_s);
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
}

/* |dn| within L/4 and the lever (fw_wire_push's domain). */
static bool wire_step_ok(const fw_wire_t *w, int32_t dn_pm, const fw_wire_static_t *st)
{
    return !(dn_pm > w->length_pm / 4 || dn_pm < -(w->length_pm / 4) || dn_pm > st->lever_pm || dn_pm < -st->lever_pm);
}

fw_status_t fw_wire_push(fw_wire_t *w, int32_t l_pm, int32_t dn_pm, fw_wire_static_t *info)
{
    fw_wire_static_t st;
    fw_status_t status;
    if (w == NULL) {
        return FW_ERR_ARG;
    }
    status = fw_wire_static_point_held(w->length_pm, l_pm, w->held, w->hold_q16, &st);
    if (status != FW_OK) {
        return status;
    }
    if (!wire_step_ok(w, dn_pm, &st)) {
        return FW_ERR_DOMAIN;
    }
    if (info != NULL) {
        *info = st;
    }
    wire_move(w, dn_pm, &st);
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

/* dot / len2 clamped to [0, 1], 2.30 (dot < 2^62, 0 <= len2 < 2^61): both
 * halved until len2 < 2^33, so dot << 30 < 2^63 below len2. */
static int64_t wire_segment_param(int64_t dot, int64_t len2)
{
    if (dot <= 0 || len2 <= 0) {
        return 0;
    }
    if (dot >= len2) {
        return FW_Q30_ONE;
    }
    while (len2 >= ((int64_t)1 << 33)) {
        len2 >>= 1;
        dot >>= 1;
    }
    return fw_math_div_round_i64(dot << FW_Q30_FRAC, len2);
}

/* One trench segment p0 -> p1 against the rod's pieces not yet held:
 * sets their bits in *held. (cx, cy): the rod's centre; (c, s): its axis. */
static void wire_hold_segment(const fw_wire_t *w, const fw_trench_point_t *p0, const fw_trench_point_t *p1,
                              q30_t c, q30_t s, uint32_t *held)
{
    const int64_t lim = (int64_t)1 << 30;
    int64_t d0x = (int64_t)p0->x_pm - w->x_pm;
    int64_t d0y = (int64_t)p0->y_pm - w->y_pm;
    int64_t sx = (int64_t)p1->x_pm - p0->x_pm;
    int64_t sy = (int64_t)p1->y_pm - p0->y_pm;
    int64_t wmax = p0->width_pm > p1->width_pm ? p0->width_pm : p1->width_pm;
    int64_t reach = wmax / 2;
    int64_t n0;
    int64_t n1;
    int64_t a0;
    int64_t a1;
    int64_t len2;
    int k;
    if (wmax < w->diameter_pm || d0x >= lim || d0x <= -lim || d0y >= lim || d0y <= -lim || sx >= lim || sx <= -lim
        || sy >= lim || sy <= -lim) {
        return;
    }
    /* both ends further than half the widest width on one side: no piece */
    n0 = fw_math_rshift_round_i64(d0y * c - d0x * s, FW_Q30_FRAC);
    n1 = fw_math_rshift_round_i64((d0y + sy) * c - (d0x + sx) * s, FW_Q30_FRAC);
    if ((n0 > reach && n1 > reach) || (n0 < -reach && n1 < -reach)) {
        return;
    }
    a0 = fw_math_rshift_round_i64(d0x * c + d0y * s, FW_Q30_FRAC);
    a1 = fw_math_rshift_round_i64((d0x + sx) * c + (d0y + sy) * s, FW_Q30_FRAC);
    len2 = sx * sx + sy * sy;
    for (k = 0; k < FW_WIRE_PIECES; k++) {
        /* the piece's midpoint, along the axis from the centre */
        int64_t m = fw_math_div_round_i64((int64_t)w->length_pm * (2 * k + 1 - FW_WIRE_PIECES), 2 * FW_WIRE_PIECES);
        int64_t mx;
        int64_t my;
        int64_t t;        /* parameter along the segment, 2.30 in [0, 1] */
        int64_t ex;
        int64_t ey;
        int64_t width;
        int64_t slack;
        if (((*held >> k) & 1u) != 0u || m < (a0 < a1 ? a0 : a1) - reach || m > (a0 > a1 ? a0 : a1) + reach) {
            continue;
        }
        mx = fw_math_rshift_round_i64(m * c, FW_Q30_FRAC) - d0x;   /* midpoint - p0 */
        my = fw_math_rshift_round_i64(m * s, FW_Q30_FRAC) - d0y;
        t = wire_segment_param(mx * sx + my * sy, len2);
        ex = mx - fw_math_rshift_round_i64(t * sx, FW_Q30_FRAC);
        ey = my - fw_math_rshift_round_i64(t * sy, FW_Q30_FRAC);
        width = p0->width_pm + fw_math_rshift_round_i64(t * ((int64_t)p1->width_pm - p0->width_pm), FW_Q30_FRAC);
        slack = width - w->diameter_pm;
        if (slack < 0) {
            continue;
        }
        /* |e| <= (width - d) / 2 = half < 2^30: each component first, then
         * the squares (< 2^61 together) */
        slack /= 2;
        if (ex > slack || ex < -slack || ey > slack || ey < -slack) {
            continue;
        }
        if (ex * ex + ey * ey <= slack * slack) {
            *held |= 1u << k;
        }
    }
}

fw_status_t fw_wire_hold(fw_wire_t *w, const fw_wire_tip_t *tip, const fw_trench_point_t *pts, int32_t n)
{
    q30_t s;
    q30_t c;
    uint32_t held = 0;
    int32_t i;
    if (w == NULL || tip == NULL) {
        return FW_ERR_ARG;
    }
    if (pts == NULL || n < 0) {
        n = 0;
    }
    if (w->hold_points == n && w->hold_at_pm[0] == w->x_pm && w->hold_at_pm[1] == w->y_pm
        && w->hold_at_psi == w->psi && w->hold_q16 == tip->hold_q16) {
        return FW_OK;
    }
    w->hold_points = n;
    w->hold_at_pm[0] = w->x_pm;
    w->hold_at_pm[1] = w->y_pm;
    w->hold_at_psi = w->psi;
    w->hold_q16 = tip->hold_q16;
    fw_math_sincos_q30(w->psi, &s, &c);
    for (i = 1; i < n; i++) {
        if ((pts[i].flags & FW_LITHO_STROKE_START) == 0u) {
            wire_hold_segment(w, &pts[i - 1], &pts[i], c, s, &held);
        }
    }
    w->held = held;
    return FW_OK;
}

/* The offset (pm, across the piece a -> b) that takes point q onto the
 * piece's path when q lies over its V (within half its mean width, its
 * projection inside the piece) and the V is at least d wide; false else. */
static bool wire_settle_offset(const int32_t q[2], const fw_trench_point_t *a, const fw_trench_point_t *b, int32_t d_pm,
                               int64_t off[2])
{
    const int64_t huge = (int64_t)1 << 30;
    const int64_t ux = (int64_t)b->x_pm - a->x_pm, uy = (int64_t)b->y_pm - a->y_pm;
    const int64_t vx = (int64_t)q[0] - a->x_pm, vy = (int64_t)q[1] - a->y_pm;
    const int64_t half_w = ((int64_t)a->width_pm + b->width_pm) / 4;
    int64_t dot, len2, len, e, nx, ny;
    if (ux >= huge || ux <= -huge || uy >= huge || uy <= -huge || vx >= huge || vx <= -huge || vy >= huge || vy <= -huge) {
        return false;
    }
    dot = ux * vx + uy * vy;   /* each product < 2^60 */
    len2 = ux * ux + uy * uy;
    if (len2 == 0 || dot <= 0 || dot >= len2 || 2 * half_w < d_pm) {
        return false;
    }
    len = (int64_t)fw_math_isqrt_round_u64((uint64_t)len2);
    e = (ux * vy - uy * vx) / len;                   /* signed distance of q to the path, left of a -> b positive */
    if (e >= half_w || e <= -half_w) {
        return false;
    }
    nx = (-uy << FW_Q30_FRAC) / len;                 /* unit normal (left), 2.30 */
    ny = (ux << FW_Q30_FRAC) / len;
    off[0] = fw_math_rshift_round_i64(-e * nx, FW_Q30_FRAC);
    off[1] = fw_math_rshift_round_i64(-e * ny, FW_Q30_FRAC);
    return true;
}

/* The seat of a rod of radius r_pm in a V of half width h_pm at the
 * surface (fw_wire_settle's header): its axis's height above the substrate
 * plane, pm. */
static int32_t wire_seat_pm(int32_t r_pm, int64_t h_pm, fw_bam_t gamma)
{
    q30_t sg, cg;
    fw_math_sincos_q30(gamma, &sg, &cg);
    if (sg <= 0) {
        return r_pm;
    }
    bool sat = false;
    return fw_math_sat_i32((((int64_t)r_pm << FW_Q30_FRAC) - h_pm * cg) / sg, &sat);
}

/* Sums over the points of a rod that lie over a groove (fw_wire_settle):
 * each point's target T_k (the point moved onto the groove's path) and its
 * place along the rod u_k = 2k + 1 - K. */
typedef struct {
    int64_t t[2];            /* sum of T_k, pm */
    int64_t ut[2];           /* sum of u_k T_k */
    int64_t u;               /* sum of u_k */
    int64_t half_w;          /* sum of the V's half widths, pm */
    int32_t held;
} wire_settle_sums_t;

static void wire_settle_gather(const fw_wire_t *w, const fw_trench_point_t *pts, int32_t n, wire_settle_sums_t *m)
{
    int32_t a[2], b[2], q[2];
    int64_t off[2];
    int32_t k, i, u;
    fw_wire_ends_pm(w, a, b);
    for (k = 0; k < FW_WIRE_SETTLE_POINTS; k++) {
        /* the point at (k + 1/2) / K from A */
        u = 2 * k + 1 - FW_WIRE_SETTLE_POINTS;
        q[0] = a[0] + (int32_t)((((int64_t)b[0] - a[0]) * (2 * k + 1)) / (2 * FW_WIRE_SETTLE_POINTS));
        q[1] = a[1] + (int32_t)((((int64_t)b[1] - a[1]) * (2 * k + 1)) / (2 * FW_WIRE_SETTLE_POINTS));
        for (i = 1; i < n; i++) {
            if ((pts[i].flags & FW_LITHO_STROKE_START) == 0u && wire_settle_offset(q, &pts[i - 1], &pts[i], w->diameter_pm, off)) {
                m->t[0] += q[0] + off[0];
                m->t[1] += q[1] + off[1];
                m->ut[0] += u * (q[0] + off[0]);
                m->ut[1] += u * (q[1] + off[1]);
                m->u += u;
                m->half_w += ((int64_t)pts[i - 1].width_pm + pts[i].width_pm) / 4;
                m->held++;
                break;
            }
        }
    }
}

bool fw_wire_settle(fw_wire_t *w, const fw_wire_tip_t *tip, const fw_trench_point_t *pts, int32_t n)
{
    wire_settle_sums_t m = {{0, 0}, {0, 0}, 0, 0, 0};
    int64_t v[2], tbar[2], along;
    q30_t sn, cs;
    if (w == NULL || tip == NULL) {
        return false;
    }
    if (pts != NULL && n >= 2) {
        wire_settle_gather(w, pts, n, &m);
    }
    if (2 * m.held < FW_WIRE_SETTLE_POINTS) {
        w->axis_z_pm = w->diameter_pm / 2;
        return false;
    }
    /* the targets' line: direction H sum u T - sum u sum T (the regression of T on u), through their mean */
    v[0] = m.held * m.ut[0] - m.u * m.t[0];
    v[1] = m.held * m.ut[1] - m.u * m.t[1];
    while (v[0] > INT32_MAX || v[0] < -INT32_MAX || v[1] > INT32_MAX || v[1] < -INT32_MAX) {
        v[0] = fw_math_asr_i64(v[0], 1);
        v[1] = fw_math_asr_i64(v[1], 1);
    }
    if (v[0] != 0 || v[1] != 0) {
        w->psi = fw_math_atan2_bam((int32_t)v[1], (int32_t)v[0]);
    }
    fw_math_sincos_q30(w->psi, &sn, &cs);
    tbar[0] = m.t[0] / m.held;
    tbar[1] = m.t[1] / m.held;
    /* the centre's foot on that line: it slides across the groove, not along it */
    along = fw_math_rshift_round_i64(((int64_t)w->x_pm - tbar[0]) * cs + ((int64_t)w->y_pm - tbar[1]) * sn, FW_Q30_FRAC);
    fw_wire_shift(w, (int32_t)(tbar[0] + fw_math_rshift_round_i64(along * cs, FW_Q30_FRAC) - w->x_pm),
                  (int32_t)(tbar[1] + fw_math_rshift_round_i64(along * sn, FW_Q30_FRAC) - w->y_pm));
    w->axis_z_pm = wire_seat_pm(w->diameter_pm / 2, m.half_w / m.held, tip->tip_half_angle);
    return true;
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

/* A trench's hold (fw_wire.h, "Trenches"): 1 / (mu tan(gamma - beta)),
 * beta = atan(mu), in 16.16 within [1, 1000]; the cap when gamma - beta <
 * 1 mrad (683565 in fw_bam_t: 2^32 / (2 pi) / 1000) or mu = 0. */
static int32_t wire_trench_hold(fw_bam_t gamma, q30_t mu)
{
    const int32_t mrad_bam = 683565;
    fw_bam_t beta = fw_math_atan2_bam(mu, FW_Q30_ONE);   /* in [0, 90 deg) */
    q30_t sn;
    q30_t cs;
    int64_t den;
    int64_t hold;
    /* gamma in (0, 60 deg): both below a half turn, compared unsigned */
    if (mu <= 0 || gamma <= beta || gamma - beta < (fw_bam_t)mrad_bam) {
        return FW_WIRE_HOLD_MAX_Q16;
    }
    fw_math_sincos_q30(gamma - beta, &sn, &cs);
    den = fw_math_rshift_round_i64((int64_t)sn * mu, FW_Q30_FRAC);
    if (den <= 0) {
        return FW_WIRE_HOLD_MAX_Q16;
    }
    hold = fw_math_div_round_i64((int64_t)cs << 16, den);
    return (int32_t)(hold > FW_WIRE_HOLD_MAX_Q16 ? FW_WIRE_HOLD_MAX_Q16
                                                  : (hold < FW_WIRE_HOLD_ONE_Q16 ? FW_WIRE_HOLD_ONE_Q16 : hold));
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
    tip->hold_q16 = wire_trench_hold(tip->tip_half_angle, tip->mu);
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

int32_t fw_wire_ride_push_pn(fw_bam_t psi, int32_t load_pn, int32_t adhesion_ts_pn)
{
    q30_t sn;
    q30_t cs;
    int64_t hold = (int64_t)load_pn + adhesion_ts_pn;
    if (hold <= 0) {
        return 0;
    }
    if (psi == 0 || psi >= FW_BAM_QUARTER_TURN) {
        return psi == 0 ? INT32_MAX : 0;
    }
    fw_math_sincos_q30(psi, &sn, &cs);
    if (sn <= 0) {
        return INT32_MAX;
    }
    return fw_math_sat_i32(fw_math_div_round_i64(hold * cs, sn), NULL);
}

/* The prior (eq. 29-30, fw_wire.h "The ride-over judgement"): the push
 * eq. 29 says moves the rod (*push_pn) and the most the tip can push before
 * it lifts (*ride_pn, H_ride). False past psi_max (the squeeze): then
 * *push_pn is half of k f L's trigger's whole (k f L). */
static bool wire_prior(const fw_wire_tip_t *tip, const fw_wire_static_t *st, int32_t fl, q30_t twist_rad,
                       int32_t load_pn, int32_t *push_pn, int32_t *ride_pn)
{
    bool sat = false;
    fw_squeeze_t sq;
    fw_status_t sqs = FW_ERR_DOMAIN;
    fw_bam_t psi = wire_contact_angle(tip, twist_rad);
    *push_pn = fw_wire_push_threshold_pn(st->k, fl, &sat);
    *ride_pn = INT32_MAX;
    if (psi < FW_BAM_QUARTER_TURN) {
        sqs = fw_wire_squeeze_solve(psi, st->k, tip->mu, fl, tip->adhesion_ts_pn, &sq);
    }
    if (sqs == FW_ERR_DOMAIN) {
        return false;
    }
    if (sqs == FW_OK) {   /* FW_ERR_ARG cannot happen (tip and k validated): then k f L stands */
        *push_pn = sq.push_pn;
        *ride_pn = fw_wire_ride_push_pn(psi, load_pn, tip->adhesion_ts_pn);
    }
    return true;
}

/* A ride-over declared (fw_wire.h, "The ride-over judgement"): latched for
 * the contact; the pushes the model made in this contact are undone when
 * they are no more than the apex's approach to the rod's line (reach). */
static void wire_ride_declare(fw_wire_t *w, int32_t reach_pm)
{
    w->judge = FW_WIRE_JUDGE_RIDE;
    w->flags |= FW_WIRE_RIDDEN;
    if (w->contact_moved_pm <= reach_pm) {
        w->x_pm = w->snap_pm[0];
        w->y_pm = w->snap_pm[1];
        w->psi = w->snap_psi;
        w->contact_moved_pm = 0;
    }
}

/* The push rule with the cone's down force for a rod no trench holds: the
 * ride-over judged from the evidence with eq. 29-30 as the prior (fw_wire.h,
 * "The ride-over judgement"). True when the rod stays this sample, with
 * FW_WIRE_SQUEEZED, FW_WIRE_RIDDEN or FW_WIRE_RIDE_PENDING raised when that
 * is why. climb_pm: the apex's height over its height before the contact;
 * depth_pm: how far the apex lies inside the reach (|dn|). */
static bool wire_pressed_stays(fw_wire_t *w, const fw_wire_tip_t *tip, const fw_wire_static_t *st, int32_t fl,
                               int64_t excess_pn, q30_t twist_rad, int32_t load_pn, int64_t climb_pm,
                               int32_t depth_pm)
{
    int32_t push;
    int32_t ride;
    const int32_t reach = tip->tip_radius_pm + w->diameter_pm / 2;
    if (w->judge == FW_WIRE_JUDGE_RIDE) {
        w->flags |= FW_WIRE_RIDDEN;
        return true;
    }
    if (climb_pm >= fw_wire_climb_on_pm(w->diameter_pm)) {
        wire_ride_declare(w, reach);
        return true;
    }
    if (!wire_prior(tip, st, fl, twist_rad, load_pn, &push, &ride)) {
        if (excess_pn > (int64_t)(push >> 1)) {
            w->flags |= FW_WIRE_SQUEEZED;
        }
        return true;
    }
    if (w->judge == FW_WIRE_JUDGE_PUSH) {
        return excess_pn <= (int64_t)((push < ride ? push : ride) >> 1);
    }
    if (push <= ride) {
        return excess_pn <= (int64_t)(push >> 1);
    }
    /* eq. 30 predicts a ride-over: the rod stays until the signals decide */
    if (excess_pn > (int64_t)(ride >> 1) &&
        (int64_t)depth_pm >= (int64_t)tip->tip_radius_pm + fw_wire_contra_extra_pm(w->diameter_pm)) {
        w->judge = FW_WIRE_JUDGE_PUSH;   /* deep past the rod's edge, no climb, still pushing */
        return false;
    }
    w->flags |= FW_WIRE_RIDE_PENDING;
    return true;
}

int32_t fw_wire_climb_on_pm(int32_t diameter_pm)
{
    int32_t on = (int32_t)(((int64_t)diameter_pm * 3) / 8);
    return on > FW_WIRE_CLIMB_FLOOR_PM ? on : FW_WIRE_CLIMB_FLOOR_PM;
}

int32_t fw_wire_contra_extra_pm(int32_t diameter_pm)
{
    return diameter_pm / 8;
}

/* The contact's bookkeeping for the judgement: a sample off the rod keeps
 * the apex's height as the baseline and ends the contact's judgement; the
 * first sample on it snapshots the rod's pose. */
static void wire_contact_track(fw_wire_t *w, bool touch, int32_t z_pm)
{
    if (!touch) {
        w->touching = false;
        w->judge = FW_WIRE_JUDGE_NONE;
        w->z_ref_pm = z_pm;
        w->z_ref_valid = true;
        return;
    }
    if (!w->touching) {
        w->touching = true;
        w->judge = FW_WIRE_JUDGE_NONE;
        w->snap_pm[0] = w->x_pm;
        w->snap_pm[1] = w->y_pm;
        w->snap_psi = w->psi;
        w->contact_moved_pm = 0;
        if (!w->z_ref_valid) {
            w->z_ref_pm = z_pm;
            w->z_ref_valid = true;
        }
    }
}

fw_status_t fw_wire_update(fw_wire_t *w, const fw_wire_tip_t *tip, const int32_t apex_pm[3], int64_t excess_pn,
                           q30_t twist_rad, int32_t load_pn)
{
    bool touch;
    bool sat = false;
    int32_t l;
    int32_t dn;
    int32_t fl;
    int32_t max_step;
    fw_wire_static_t st;
    int steps;
    int64_t moved = 0;
    if (w == NULL || tip == NULL || apex_pm == NULL) {
        return FW_ERR_ARG;
    }
    w->flags &= ~(FW_WIRE_PUSHED | FW_WIRE_SQUEEZED | FW_WIRE_RIDDEN | FW_WIRE_RIDE_PENDING);
    if (fw_wire_contact(w, apex_pm, tip->tip_radius_pm + w->diameter_pm / 2, &touch, &l, &dn) != FW_OK) {
        return FW_OK;
    }
    wire_contact_track(w, touch, apex_pm[2]);
    if (!touch) {
        return FW_OK;
    }
    if (fw_wire_static_point_held(w->length_pm, l, w->held, w->hold_q16, &st) != FW_OK) {
        return FW_OK;
    }
    fl = fw_wire_friction_pn(tip, w);
    /* held: the whole push (fw_wire.h, "Trenches"), k_q16 <= 1000 * 2^16
     * < 2^26 times f L < 2^31: < 2^57; pressed by the cone: eq. 29 and
     * 30 (wire_pressed_stays); else half of k f L, k in 2.30 as
     * fw_wire_push_threshold_pn has it */
    if (w->held != 0u) {
        if (excess_pn <= fw_math_rshift_round_i64((int64_t)st.k_q16 * fl, 16)) {
            return FW_OK;
        }
    } else if (tip->down_force) {
        if (wire_pressed_stays(w, tip, &st, fl, excess_pn, twist_rad, load_pn,
                               (int64_t)apex_pm[2] - w->z_ref_pm, dn < 0 ? -dn : dn)) {
            return FW_OK;
        }
    } else if (excess_pn <= (int64_t)(fw_wire_push_threshold_pn(st.k, fl, &sat) >> 1)) {
        return FW_OK;
    }
    /* first order: at most L/4, and a quarter of the lever (L/16 or more
     * on a held rod), so each step turns it by under a quarter radian */
    max_step = w->length_pm / 4;
    if (max_step > st.lever_pm / 4) {
        max_step = st.lever_pm / 4;
    }
    if (max_step < 1) {
        max_step = 1;   /* rods of under 4 pm (shorter ones are refused: L >= d > 0) */
    }
    for (steps = 0; dn != 0 && steps < FW_WIRE_PUSH_STEPS_MAX; steps++) {
        int32_t step = (dn > max_step) ? max_step : ((dn < -max_step) ? -max_step : dn);
        /* the same l and held pieces each step: st stands (fw_wire_push
         * would solve it again) */
        if (!wire_step_ok(w, step, &st)) {
            break;
        }
        wire_move(w, step, &st);
        dn -= step;
        moved += step < 0 ? -step : step;
    }
    w->contact_moved_pm = fw_math_sat_i32((int64_t)w->contact_moved_pm + moved, NULL);
    w->flags |= FW_WIRE_PUSHED;
    return FW_OK;
}
