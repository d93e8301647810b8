/*
 * fw_particles.c - see fw_particles.h.
 */
#include "fw_particles.h"
#include "fw_math.h"

/* Radii are limited so that a distance of two radii, squared, and the sum of
 * two such squares stay below 2^63. */
#define PARTICLES_RADIUS_MAX_PM ((int32_t)1 << 30)
/* Vectors are normalised at this magnitude before their length is taken, so
 * the integer length is exact to 2^-31 relative. */
#define PARTICLES_NORM_BIT 30
#define PARTICLES_MOVED (FW_PARTICLE_PUSHED | FW_PARTICLE_CHAINED)

fw_rule_t fw_particles_check(int32_t tip_radius_pm)
{
    return (tip_radius_pm < 0 || tip_radius_pm > PARTICLES_RADIUS_MAX_PM) ? FW_RULE_TIP_RADIUS : FW_RULE_OK;
}

fw_rule_t fw_particles_check_particle(int32_t radius_pm, int32_t threshold_pn)
{
    return (radius_pm <= 0 || radius_pm > PARTICLES_RADIUS_MAX_PM || threshold_pn < 0) ? FW_RULE_PARTICLE
                                                                                       : FW_RULE_OK;
}

fw_status_t fw_particles_init(fw_particles_t *m, fw_particle_t *storage, int32_t capacity, int32_t tip_radius_pm)
{
    int32_t i;
    if (m == NULL || capacity < 0 || (storage == NULL && capacity > 0)) {
        return FW_ERR_ARG;
    }
    if (fw_particles_check(tip_radius_pm) != FW_RULE_OK) {
        return fw_rule_status(fw_particles_check(tip_radius_pm));
    }
    for (i = 0; i < capacity; i++) {
        storage[i].id = 0;
        storage[i].x_pm = 0;
        storage[i].y_pm = 0;
        storage[i].radius_pm = 0;
        storage[i].threshold_pn = 0;
        storage[i].flags = 0;
    }
    m->p = storage;
    m->capacity = capacity;
    m->count = 0;
    m->tip_radius_pm = tip_radius_pm;
    m->margin_pn = 0;
    m->flags = 0;
    m->push_count = 0;
    return FW_OK;
}

fw_status_t fw_particles_set_margin(fw_particles_t *m, int32_t margin_pn)
{
    if (m == NULL || margin_pn < 0) {
        return FW_ERR_ARG;
    }
    m->margin_pn = margin_pn;
    return FW_OK;
}

fw_status_t fw_particles_add(fw_particles_t *m, int32_t id, int32_t x_pm, int32_t y_pm, int32_t radius_pm, int32_t threshold_pn)
{
    fw_particle_t *p;
    fw_rule_t rule = fw_particles_check_particle(radius_pm, threshold_pn);
    if (m == NULL) {
        return FW_ERR_ARG;
    }
    if (rule != FW_RULE_OK) {
        return fw_rule_status(rule);
    }
    if (m->count >= m->capacity) {
        return FW_ERR_CAPACITY;
    }
    p = &m->p[m->count];
    p->id = id;
    p->x_pm = x_pm;
    p->y_pm = y_pm;
    p->radius_pm = radius_pm;
    p->threshold_pn = threshold_pn;
    p->flags = 0;
    m->count++;
    return FW_OK;
}

/* Place *p at distance dist from (ax, ay) along (vx, vy) (nonzero).
 * Scaling and overflow: v is scaled so max(|vx|, |vy|) lies in
 * [2^30, 2^31) (sum of squares < 2^63), its rounded length is then exact to
 * 2^-31; dist * v < 2^62; the result is saturated to int32. */
static void particles_place(fw_particle_t *p, int64_t ax, int64_t ay, int64_t vx, int64_t vy,
                            int64_t dist)
{
    int64_t mx = vx < 0 ? -vx : vx;
    int64_t my = vy < 0 ? -vy : vy;
    int64_t mm = mx > my ? mx : my;
    uint64_t len;
    bool sat = false;
    while (mm >= ((int64_t)1 << (PARTICLES_NORM_BIT + 1))) {
        vx = fw_math_rshift_round_i64(vx, 1);
        vy = fw_math_rshift_round_i64(vy, 1);
        mm >>= 1;
    }
    while (mm < ((int64_t)1 << PARTICLES_NORM_BIT)) {
        vx *= 2;
        vy *= 2;
        mm *= 2;
    }
    len = fw_math_isqrt_round_u64((uint64_t)(vx * vx) + (uint64_t)(vy * vy));
    p->x_pm = fw_math_sat_i32(ax + fw_math_div_round_i64(dist * vx, (int64_t)len), &sat);
    p->y_pm = fw_math_sat_i32(ay + fw_math_div_round_i64(dist * vy, (int64_t)len), &sat);
    if (sat) {
        p->flags |= FW_PARTICLE_SAT_POS;
    }
}

/* true if the centre lies closer than dist to (ax, ay) in the plane. */
static bool particles_within(int64_t dx, int64_t dy, int64_t dist)
{
    if (dx >= dist || -dx >= dist || dy >= dist || -dy >= dist) {
        return false;
    }
    return (uint64_t)(dx * dx) + (uint64_t)(dy * dy) < (uint64_t)(dist * dist);
}

fw_status_t fw_particles_update(fw_particles_t *m, const int32_t tip_pm[2], const int32_t force_xy_pn[2],
                                int64_t excess_pn)
{
    int64_t pdx;
    int64_t pdy;
    int32_t i;
    int32_t j;
    int32_t pass;
    bool moved = false;
    if (m == NULL || tip_pm == NULL || force_xy_pn == NULL) {
        return FW_ERR_ARG;
    }
    m->flags = 0;
    for (i = 0; i < m->count; i++) {
        m->p[i].flags &= ~(PARTICLES_MOVED | FW_PARTICLE_OVERLAP);
    }
    /* push direction: opposite to the force on the tip */
    pdx = -(int64_t)force_xy_pn[0];
    pdy = -(int64_t)force_xy_pn[1];
    if (pdx == 0 && pdy == 0) {
        pdx = 1;
    }
    for (i = 0; i < m->count; i++) {
        fw_particle_t *p = &m->p[i];
        int64_t dist = (int64_t)m->tip_radius_pm + p->radius_pm;
        int64_t vx = (int64_t)p->x_pm - tip_pm[0];
        int64_t vy = (int64_t)p->y_pm - tip_pm[1];
        if (!particles_within(vx, vy, dist)) {
            continue;
        }
        if (excess_pn <= (int64_t)m->margin_pn + (p->threshold_pn >> FW_PARTICLES_CONTACT_SHIFT)) {
            p->flags |= FW_PARTICLE_OVERLAP;
            continue;
        }
        if (vx == 0 && vy == 0) {
            vx = pdx;
            vy = pdy;
        }
        particles_place(p, tip_pm[0], tip_pm[1], vx, vy, dist);
        p->flags |= FW_PARTICLE_PUSHED;
        moved = true;
    }
    /* chain: moved particles push the neighbours they now overlap */
    for (pass = 0; moved && pass < FW_PARTICLES_CHAIN_MAX; pass++) {
        moved = false;
        for (i = 0; i < m->count; i++) {
            const fw_particle_t *a = &m->p[i];
            if ((a->flags & PARTICLES_MOVED) == 0u) {
                continue;
            }
            for (j = 0; j < m->count; j++) {
                fw_particle_t *q = &m->p[j];
                int64_t dist = (int64_t)a->radius_pm + q->radius_pm;
                int64_t vx = (int64_t)q->x_pm - a->x_pm;
                int64_t vy = (int64_t)q->y_pm - a->y_pm;
                if (j == i || !particles_within(vx, vy, dist)) {
                    continue;
                }
                if (vx == 0 && vy == 0) {
                    vx = pdx;
                    vy = pdy;
                }
                particles_place(q, a->x_pm, a->y_pm, vx, vy, dist);
                q->flags |= FW_PARTICLE_CHAINED;
                moved = true;
            }
        }
    }
    for (i = 0; i < m->count; i++) {
        if ((m->p[i].flags & FW_PARTICLE_PUSHED) != 0u) {
            m->flags = FW_FLAG_CONTACT;
        }
    }
    if (m->flags != 0u && m->push_count != UINT32_MAX) {
        m->push_count++;
    }
    return FW_OK;
}

int32_t fw_particles_count(const fw_particles_t *m)
{
    return (m == NULL) ? 0 : m->count;
}

const fw_particle_t *fw_particles_get(const fw_particles_t *m, int32_t i)
{
    if (m == NULL || i < 0 || i >= m->count) {
        return NULL;
    }
    return &m->p[i];
}

uint32_t fw_particles_flags(const fw_particles_t *m)
{
    return (m == NULL) ? 0u : m->flags;
}

void fw_particles_shift(fw_particles_t *m, int32_t dx_pm, int32_t dy_pm)
{
    int32_t i;
    if (m == NULL) {
        return;
    }
    for (i = 0; i < m->count; i++) {
        bool sat = false;
        m->p[i].x_pm = fw_math_sat_i32((int64_t)m->p[i].x_pm + dx_pm, &sat);
        m->p[i].y_pm = fw_math_sat_i32((int64_t)m->p[i].y_pm + dy_pm, &sat);
        if (sat) {
            m->p[i].flags |= FW_PARTICLE_SAT_POS;
        }
    }
}

int32_t fw_particles_threshold_pn(int32_t mu_ppm, int32_t adhesion_pn, int32_t down_pn, int32_t shear_kpa,
                                  int32_t contact_area_nm2)
{
    int64_t f = fw_math_div_round_i64((int64_t)mu_ppm * ((int64_t)adhesion_pn + down_pn), FW_PPM_PER_ONE)
                + fw_math_div_round_i64((int64_t)shear_kpa * contact_area_nm2, 1000);
    return fw_math_sat_i32(f < 0 ? 0 : f, NULL);
}

int32_t fw_particles_down_threshold_pn(int32_t base_pn, int32_t mu_ppm, fw_bam_t psi)
{
    q30_t sn;
    q30_t cs;
    int64_t den;
    if (base_pn <= 0) {
        return 0;
    }
    if (psi >= FW_BAM_QUARTER_TURN) {
        return INT32_MAX;
    }
    fw_math_sincos_q30(psi, &sn, &cs);
    den = (int64_t)cs - fw_math_div_round_i64((int64_t)(mu_ppm < 0 ? 0 : mu_ppm) * sn, FW_PPM_PER_ONE);
    if (den <= 0) {
        return INT32_MAX;
    }
    return fw_math_sat_i32(fw_math_div_round_i64((int64_t)base_pn * cs, den), NULL);
}
