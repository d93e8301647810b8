/*
 * fw_models.c - the card's models as one snapshot (fw_models.h).
 */
#include "fw_models.h"

#include <stddef.h>

fw_status_t fw_models_take(const fw_card_t *c, fw_models_t *m)
{
    if (c == NULL || m == NULL) return FW_ERR_ARG;
    const fw_particles_t *parts = fw_card_particles(c);
    const int32_t np = fw_particles_count(parts);
    const int32_t nw = fw_card_wire_count(c);
    m->n_particles = 0;
    m->n_wires = 0;
    if (np > m->particle_capacity || nw > m->wire_capacity) return FW_ERR_CAPACITY;
    for (int32_t i = 0; i < np; ++i) {
        const fw_particle_t *p = fw_particles_get(parts, i);
        fw_models_particle_t *q = &m->particles[i];
        q->id = p->id;
        q->x_pm = p->x_pm;
        q->y_pm = p->y_pm;
        q->radius_pm = p->radius_pm;
        q->flags = p->flags;
    }
    for (int32_t i = 0; i < nw; ++i) {
        const fw_wire_t *w = fw_card_wire(c, i);
        fw_models_wire_t *q = &m->wires[i];
        q->id = fw_card_wire_id(c, i);
        fw_wire_ends_pm(w, q->a_pm, q->b_pm);
        q->diameter_pm = w->diameter_pm;
        q->flags = w->flags;
        q->axis_z_pm = w->axis_z_pm;
    }
    m->n_particles = np;
    m->n_wires = nw;
    const fw_litho_t *litho = fw_card_litho(c);
    m->litho = litho != NULL;
    m->trench = litho ? litho->pts : NULL;
    m->trench_count = litho ? litho->count : 0;
    fw_card_drift_pm(c, m->drift_pm);
    const fw_guard_t *guard = fw_card_guard(c);
    m->interlock = guard != NULL;
    m->interlock_trips = guard ? guard->trips : 0u;
    return FW_OK;
}
