/*
 * fw_models.h - the card's object models as the host publishes them: one
 * snapshot, taken after each block and each fix, drift or place (pil.md).
 *
 * The host's adapter (host/card/card_node) reads the card's models
 * only through this snapshot, whether the card runs in the same process
 * (fw_models_take on the host build) or on the board (the board takes it
 * and sends it with every answer, fw_marshal.h). What it holds:
 *   - each particle: id, position, radius, flags (not its threshold);
 *   - each wire: id, ends A and B (fw_wire_ends_pm), diameter, flags, and
 *     its axis's height (fw_wire_t.axis_z_pm: lower when seated in a groove);
 *   - the trench points the card has recorded (fw_litho), by pointer: into
 *     the card on the host build, into the host's copy on the board build;
 *   - the accumulated drift, and the interlock's trips (when it is on).
 * Contract: the caller's arrays hold at least the card's counts; the card
 * is only read. No arithmetic beyond fw_wire_ends_pm's.
 */
#ifndef FW_MODELS_H
#define FW_MODELS_H

#include "fw_card.h"

typedef struct { int32_t id; int32_t x_pm; int32_t y_pm; int32_t radius_pm; uint32_t flags; } fw_models_particle_t;
typedef struct { int32_t id; int32_t a_pm[2]; int32_t b_pm[2]; int32_t diameter_pm; uint32_t flags; int32_t axis_z_pm; } fw_models_wire_t;

typedef struct {
    fw_models_particle_t *particles;   /* caller's storage */
    int32_t particle_capacity;
    int32_t n_particles;
    fw_models_wire_t *wires;           /* caller's storage */
    int32_t wire_capacity;
    int32_t n_wires;
    bool litho;                        /* the card cuts: trench is meaningful */
    const fw_trench_point_t *trench;   /* trench_count points, in the card's order */
    int32_t trench_count;
    int32_t drift_pm[2];               /* accumulated drift, frame A */
    bool interlock;                    /* the interlock is on: interlock_trips counts */
    uint32_t interlock_trips;          /* blocks that tripped since reset (fw_guard_t.trips) */
} fw_models_t;

/* Fills m from the card (its storage and capacities as set by the caller).
 * FW_ERR_ARG for a NULL pointer, FW_ERR_CAPACITY (m's counts then 0) when
 * the card holds more particles or wires than m's storage. The trench
 * pointer points into the card (valid until its next step, fix or reset).
 * Scaling and overflow: none; positions are the card's, ends as
 * fw_wire_ends_pm gives them. */
fw_status_t fw_models_take(const fw_card_t *c, fw_models_t *m);

#endif /* FW_MODELS_H */
