/*
 * fw_particles.h - model of nanoparticles pushed by the tip (physics.md
 * section 5), caller-owned storage, no allocation.
 *
 * Contact test, per update, per particle:
 *  - geometry: horizontal distance apex-centre < r_tip + r_p;
 *  - force: the lateral force in excess of the tip-substrate friction,
 *      excess = |F_xy| - mu (F_z + F_adh)     (fw_force_lateral_excess_pn)
 *    must exceed margin_pn + threshold_pn / 2 (FW_PARTICLES_CONTACT_SHIFT). While a particle slides
 *    quasi-statically the excess equals its threshold F_th; with no particle
 *    it is 0; half the threshold is the decision midpoint, and margin_pn
 *    (default 0, fw_particles_set_margin) absorbs noise. The caller (the
 *    card) forms the excess once per sample for every object model.
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
#include "fw_rules.h"

#define FW_PARTICLES_CHAIN_MAX 8

/* Contact needs an excess above threshold >> FW_PARTICLES_CONTACT_SHIFT
 * (half the threshold: the decision midpoint). A test-only build
 * (FW_TEST_PERTURB, never a product build) makes it a quarter, one
 * changed constant that replay must find (tests/e2e/test_replay.py). */
#if defined(FW_TEST_PERTURB)
#define FW_PARTICLES_CONTACT_SHIFT 2
#else
#define FW_PARTICLES_CONTACT_SHIFT 1
#endif

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
    int32_t margin_pn;       /* contact needs excess > margin + threshold / 2 */
    uint32_t flags;          /* FW_FLAG_CONTACT if a particle was pushed in the last update */
    uint32_t push_count;     /* updates with contact since init (saturating) */
} fw_particles_t;

/* The first rule broken: tip radius outside [0, 2^30] pm
 * (FW_RULE_TIP_RADIUS). */
fw_rule_t fw_particles_check(int32_t tip_radius_pm);
/* The first rule a particle breaks: radius outside (0, 2^30] pm or
 * threshold < 0 pN (FW_RULE_PARTICLE). */
fw_rule_t fw_particles_check_particle(int32_t radius_pm, int32_t threshold_pn);

/* Validates with fw_particles_check (FW_ERR_ARG also for a NULL m, a
 * negative capacity, or NULL storage with a capacity > 0; no storage with
 * capacity 0 is a model that holds none); zeroes the storage; margin 0. */
fw_status_t fw_particles_init(fw_particles_t *m, fw_particle_t *storage, int32_t capacity, int32_t tip_radius_pm);
/* Appends a particle (fw_particles_check_particle; FW_ERR_CAPACITY when
 * the storage is full). */
fw_status_t fw_particles_add(fw_particles_t *m, int32_t id, int32_t x_pm, int32_t y_pm, int32_t radius_pm, int32_t threshold_pn);
/* One update: apex (frame A, pm), the lateral force on the tip (frame A,
 * pN; its opposite is the push direction when the apex sits exactly on a
 * centre) and the contact force excess_pn (above). FW_ERR_ARG for a NULL
 * pointer. Scaling and overflow: as particles_place and the 64-bit
 * distance tests (fw_particles.c). */
fw_status_t fw_particles_update(fw_particles_t *m, const int32_t tip_pm[2], const int32_t force_xy_pn[2],
                                int64_t excess_pn);
int32_t     fw_particles_count(const fw_particles_t *m);
const fw_particle_t *fw_particles_get(const fw_particles_t *m, int32_t i);

/* The push threshold of a particle (physics.md section 5):
 *   F_th = mu_ps (F_adh,ps + F_down) + tau_ps A_c       (pN)
 * from mu_ps (ppm), F_adh,ps and F_down (pN), tau_ps (kPa) and A_c (nm^2):
 * 1 kPa nm^2 = 10^-3 pN. Scaling and overflow: mu (F_adh + F_down) <
 * 2^20 2^32 in 64 bits, rounded; tau A < 2^62, rounded; the sum saturated
 * to int32. Negative inputs are a caller bug: the result is clamped at 0. */
int32_t fw_particles_threshold_pn(int32_t mu_ppm, int32_t adhesion_pn, int32_t down_pn, int32_t shear_kpa,
                                  int32_t contact_area_nm2);

/* The threshold with the cone's down force (physics.md section 5 with
 * F_down = H tan psi, the vertical part of a push H through the cone's
 * flank at psi = gamma from the horizontal: the flank touches any particle
 * of r_p >= r_tip (1 - sin gamma) / (1 + sin gamma)). The particle moves
 * when H >= mu_ps (F_adh,ps + H tan psi) + tau_ps A_c, i.e.
 *   H_th = base / (1 - mu_ps tan psi) = base cos psi / (cos psi - mu_ps sin psi)
 * with base = fw_particles_threshold_pn(.., F_down = 0, ..). At or past
 * psi_max = atan(1 / mu_ps) no push moves it (the cone squeezes it):
 * INT32_MAX. psi in [0, 90 deg) (INT32_MAX beyond), base >= 0 (0 below).
 * Scaling and overflow: cos, sin in 2.30; mu sin = mu_ppm sin / 10^6 in
 * 64 bits (< 2^52); base cos < 2^61; the quotient saturated to int32. */
int32_t fw_particles_down_threshold_pn(int32_t base_pn, int32_t mu_ppm, fw_bam_t psi);

/* Contact margin above half the threshold, >= 0 pN (FW_ERR_ARG otherwise). */
fw_status_t fw_particles_set_margin(fw_particles_t *m, int32_t margin_pn);

/* FW_FLAG_CONTACT if the last update pushed a particle, else 0: OR it into
 * the sample's flags. */
uint32_t fw_particles_flags(const fw_particles_t *m);

/* Shift every particle by (dx, dy) pm (drift correction), saturated. */
void fw_particles_shift(fw_particles_t *m, int32_t dx_pm, int32_t dy_pm);

#endif /* FW_PARTICLES_H */
