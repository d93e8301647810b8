/*
 * fw_particles.h - model of nanoparticles pushed by the tip (physics.md
 * section 5), caller-owned storage, no allocation.
 *
 * Contact test, per update, per particle:
 *  - geometry: horizontal distance apex-centre < r_tip + r_p;
 *  - force: the lateral force in excess of the tip-substrate friction,
 *      excess = |F_xy| - mu (F_z + F_adh)       (clamped at 0)
 *    must exceed margin_pn + threshold_pn / 2. While a particle slides
 *    quasi-statically the excess equals its threshold F_th; with no particle
 *    it is 0; half the threshold is the decision midpoint, and margin_pn
 *    (default 0) absorbs noise. mu, F_adh, margin: fw_particles_set_friction
 *    (defaults 0).
 *    If board_flags has FW_FLAG_SAT_SL the lateral force is at least its
 *    clamped value, still used as is.
 * A particle in contact is projected along the line of centres:
 *   new centre = apex + (r_tip + r_p) * unit(old centre - apex)
 * If the apex sits exactly on the centre, the push direction -F_xy/|F_xy|
 * (force on the tip opposes the push) is used; never a division by zero.
 * A moved particle pushes any neighbour it then overlaps (distance <
 * r_i + r_j) along their line of centres, breadth first, at most
 * FW_PARTICLES_CHAIN_MAX passes. The apex z is not used.
 */
#ifndef FW_PARTICLES_H
#define FW_PARTICLES_H

#include "fw_types.h"

#define FW_PARTICLES_CHAIN_MAX 8

/* fw_particle_t.flags */
#define FW_PARTICLE_PUSHED   (1u << 0)  /* moved by the tip in the last update */
#define FW_PARTICLE_CHAINED  (1u << 1)  /* moved by a neighbour in the last update */
#define FW_PARTICLE_OVERLAP  (1u << 2)  /* apex overlaps it but the force shows no contact */
#define FW_PARTICLE_SAT_POS  (1u << 3)  /* a move was clamped to int32 */

typedef struct { int32_t id; int32_t x_pm; int32_t y_pm; int32_t radius_pm; int32_t threshold_pn; uint32_t flags; } fw_particle_t;

typedef struct {
    fw_particle_t *p;        /* caller-owned storage */
    int32_t capacity;
    int32_t count;
    int32_t tip_radius_pm;
    int32_t mu_ppm;          /* tip-substrate friction baseline */
    int32_t adhesion_pn;
    int32_t margin_pn;
    uint32_t flags;          /* FW_FLAG_CONTACT if a particle was pushed in the last update */
    uint32_t push_count;     /* updates with contact since init (saturating) */
} fw_particles_t;

fw_status_t fw_particles_init(fw_particles_t *m, fw_particle_t *storage, int32_t capacity, int32_t tip_radius_pm);
fw_status_t fw_particles_add(fw_particles_t *m, int32_t id, int32_t x_pm, int32_t y_pm, int32_t radius_pm, int32_t threshold_pn);
fw_status_t fw_particles_update(fw_particles_t *m, const int32_t tip_pm[3], const int32_t force_pn[3], uint32_t board_flags);
int32_t     fw_particles_count(const fw_particles_t *m);
const fw_particle_t *fw_particles_get(const fw_particles_t *m, int32_t i);

/* Tip-substrate friction baseline for the contact test: mu (ppm, 0..1e6),
 * F_adh >= 0 (pN), margin >= 0 (pN). */
fw_status_t fw_particles_set_friction(fw_particles_t *m, int32_t mu_ppm, int32_t adhesion_pn, int32_t margin_pn);

/* FW_FLAG_CONTACT if the last update pushed a particle, else 0: OR it into
 * the sample's flags. */
uint32_t fw_particles_flags(const fw_particles_t *m);

/* Shift every particle by (dx, dy) pm (drift correction), saturated. */
void fw_particles_shift(fw_particles_t *m, int32_t dx_pm, int32_t dy_pm);

#endif /* FW_PARTICLES_H */
