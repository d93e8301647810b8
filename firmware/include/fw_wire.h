/*
 * fw_wire.h - rigid nanowire pushed by the tip (physics.md section 6) and
 * the tip-substrate-wire squeeze (section 7).
 *
 * Rod of length L from end A (l = 0) to end B (l = L), pushed perpendicular
 * to its axis at l. Torque and force balance with uniform friction density f
 * give the static point S at s from A (eq. 20), with Q = (l - L/2)^2 + L^2/4:
 *   l < L/2: s = l + sqrt(Q)  (S in [L/sqrt2, L], near B)
 *   l > L/2: s = l - sqrt(Q)  (S in [0, (1 - 1/sqrt2) L], near A)
 *   l = L/2: pure translation, S undefined (bifurcation).
 * Minimum push, as the net friction |L - 2s| f:
 *   k(l) = F_min / (f L) = (2 sqrt(Q) - |L - 2l|) / L
 *        = 1 / (sqrt(u^2 + 1) + |u|),  u = (2l - L) / L
 * which is sqrt2 - 1 = 0.414 at the ends and 1 at the middle. NOTE:
 * physics.md prints F_min = f (2 sqrt(Q) - L); that agrees only at l = 0
 * (it gives 0 at the middle, where it states f L); |L - 2s| f is what
 * the balance gives and what is implemented.
 *
 * Motion (first order in the push step dn along the wire's normal):
 *   dpsi = w dn / (l - s),   l - s = sign(u) sqrt(Q), |l - s| >= L/2
 * so the division is by at least L/2 (L/16 on a rod a trench holds,
 * below). Near the middle the quasi-
 * static solution flips from "rotate about B" to "rotate about A"; the
 * update blends to pure translation there:
 *   w = min(1, |u| / FW_WIRE_BLEND_U)   (FW_WIRE_BLEND_U = 1/8: l within L/16
 *                                        of the middle)
 *   centre normal step = dn (w (L/2 - s) / (l - s) + (1 - w))
 * i.e. rotation about an effective pivot that runs to infinity as
 * w -> 0, continuous in l through L/2 (the paper: avoid pushing the exact
 * middle; zigzag end pushes instead).
 *
 * The push rule (fw_wire_update, per sample): a rod the apex touches (its
 * footprint is the rectangle of its axis widened by r_tip + d/2) is pushed
 * when the contact force, the lateral force in excess of the tip's own
 * friction (fw_force_lateral_excess_pn), exceeds half of the push that
 * moves it. That push is the model's: k(l) f L without the cone's down
 * force; with it (tip.down_force, eq. 23-24 and 29: the cone presses the
 * rod by F_r sin psi, so its friction is mu (F_a,os + F_r sin psi) + tau A)
 * the horizontal part of eq. 29, F_r cos psi = k f L / (1 - k mu tan psi).
 * Why half and not the whole: it is the decision midpoint between "no rod"
 * (the excess is 0) and "a rod that slides" (the excess is the model's push,
 * plus the photodiode's noise). A trigger at the whole value misses about
 * half of the sliding samples, and each miss leaves the model rod behind
 * the apex; a trigger at half moves the model early only while the contact
 * force builds, by the contact's compliance (the apex does not pass the
 * rod's surface, fw_wire_contact). test_wire pins both edges. With the down
 * force, psi = gamma + theta_t at or past psi_max is the squeeze (section
 * 7): the rod stays and FW_WIRE_SQUEEZED is raised once the excess passes
 * half of k f L. Below psi_max the tip may leave the substrate: see "The
 * ride-over judgement". A pushed rod moves along its normal until the apex
 * sits on its surface, in steps of at most L/4 (fw_wire_push),
 * FW_WIRE_PUSH_STEPS_MAX of them at most.
 *
 * The ride-over judgement (with the down force, a rod no trench holds;
 * physics.md section 7). The prior is eq. 30: the tip leaves the substrate
 * when its load F_z cannot hold it down against the push (dF = F_r sin psi
 * - F_a,ts above F_z), i.e. when eq. 29's push exceeds the most the tip can
 * push before it lifts, H_ride = (F_z + F_a,ts) / tan psi (the tip's
 * vertical balance, eq. 27-28). Near dF the card's own constants decide
 * that comparison, so the card declares a ride-over only from its signals:
 *   - the climb: the apex's height (the z piezo's, apex_pm[2]) rises over
 *     its height at the last sample off the rod (z_ref) by at least
 *     max(3 d / 8, 2 nm) (fw_wire_climb_on_pm). A tip that rides over climbs
 *     by up to d, by d / 2 or more once its apex is over the rod's edge (by
 *     r_tip past the contact); a tip that pushes stays down, its height
 *     wandering by the lever's bending under the push's F_x and the
 *     substrate's tilt over the push: up to 26 nm over 40 nN pushes on the
 *     paper's lever (./afm bench rideover), growing with the push. 3 d / 8
 *     (37.5 nm on the paper's 100 nm rod) lies between the two; a thinner
 *     rod, or a harder push, loses that margin.
 *     The climb counts whatever the prior says: pushes the model made in
 *     the contact, if no more than the reach r_tip + d/2 in all (the apex's
 *     approach before the climb shows), are undone (the pose the contact
 *     began with is restored: the rod ridden over never moved).
 *   The lateral force is no evidence of its own: it falls when the tip
 *   rides over, but also when the pushed rod slips ahead of the tip (a
 *   stroke's end), where the apex then stands deep in the model's lagging
 *   rod; taken as evidence it flagged pushes (./afm bench rideover).
 * The climb declares it (FW_WIRE_JUDGE_RIDE, FW_WIRE_RIDDEN each sample): the
 * rod stays, latched until the apex leaves the rod's reach (that latch is
 * the hysteresis: a climb noisy about its threshold cannot chatter). While
 * eq. 30 predicts a ride-over and the climb has not shown, the rod stays and
 * FW_WIRE_RIDE_PENDING is raised, not FW_WIRE_RIDDEN. The signals
 * contradict the prediction when the apex stands r_tip + d / 8 or more
 * inside the reach (fw_wire_contra_extra_pm: past where a ride-over's climb
 * shows, by a margin) with no climb and the excess above half of H_ride:
 * the truth's rod is in front of the apex, pushed. Then (FW_WIRE_JUDGE_PUSH,
 * until the contact ends or the climb shows) the rod moves as pushed,
 * caught up at once to the apex's surface, while the excess passes half of
 * the lesser of eq. 29's push and H_ride. Where eq. 30 predicts a push the
 * rule is the push rule above (the climb still declares a ride-over).
 * Latency, at the paper's 1.5 um/s and 1000 blocks/s (1.5 nm a block): a
 * ride-over shows its climb once the apex has passed r_tip past the
 * contact (10 nm: about 7 blocks); a push eq. 30 misjudged is taken up
 * after r_tip + d / 8 (22.5 nm: about 15 blocks), the model rod that far
 * behind until then. Without the down force the card models no ride-over
 * (nor does the simulator: no cone flank to climb).
 *
 * Trenches (physics.md section 9, the paper's fig. 18): a lithography
 * trench (fw_litho's record) holds a rod where its V, of the recorded width
 * 2 depth tan gamma, is at least as wide as the rod and the rod's axis lies
 * within (width - d) / 2 of the trench's path (the simulator's rule,
 * World::trench_hold). To leave it sideways the rod climbs a wall inclined
 * at theta = 90 deg - gamma against its friction angle beta = atan(mu): its
 * friction across the trench is
 *   hold = tan(theta + beta) / tan(beta) = 1 / (mu tan(gamma - beta))
 * times its friction along it, FW_WIRE_HOLD_MAX when gamma - beta is under
 * 1 mrad (the wall is then too steep to climb; mu = 0 included). The rod is
 * cut into FW_WIRE_PIECES equal pieces (bit k of fw_wire_t.held: piece k
 * from A, held when its midpoint is); a push across moves a held piece
 * against hold f per length, the others against f. The static point then
 * solves the same torque balance with that density (eq. 20 generalised,
 * fw_wire_static_point_held): a rod held at one end turns about the held
 * part, a rod held along its whole length needs hold times the push. A
 * held rod is pushed only when the excess passes the whole of that push,
 * not half of it: the midpoint rule assumes a rod that slides as soon as
 * it is pushed, but a rod stuck in a trench is pressed by the tip with
 * anything up to the contact's stiffness times the push's overshoot, and
 * half of a large hold is well inside that (the simulator then keeps the
 * rod while the model would move it). The cost is the lag the midpoint
 * avoids on a free rod: a held rod that turns about its held part is
 * followed on the samples whose excess is above the model's push. The
 * cone's down force (eq. 29) is not applied to a held rod: the walls carry
 * it (the simulator does the same). Known difference: the hold here is
 * isotropic, charged on a held piece whatever the trench's direction; the
 * simulator charges it only across the trench (its friction metric). The
 * card's rods move along their normals, so the two agree for a rod lying
 * along the trench (fig. 18, the experiment `trench`) and part for a rod
 * crossing one (the card then needs a larger push than the simulator).
 * Cost: fw_wire_hold scans every recorded point (at most the card's
 * storage) on each sample a rod has moved or a point was added. No trench, or no held piece: the
 * closed forms above, exactly.
 *
 * Units: lengths pm (L in (0, 2^30]), angles fw_bam_t, k in 2.30.
 */
#ifndef FW_WIRE_H
#define FW_WIRE_H

#include "fw_types.h"
#include "fw_rules.h"
#include "fw_litho.h"

#define FW_WIRE_LENGTH_MAX_PM ((int32_t)1 << 30)
#define FW_WIRE_BLEND_U ((q30_t)(FW_Q30_ONE / 8))
#define FW_WIRE_MU_MAX_PPM 1999999               /* the squeeze's mu lies in [0, 2) */
/* A push moves the rod in steps of at most L/4 (fw_wire_push's first-order
 * limit), at most this many per sample: 16 L, far beyond the apex's reach
 * r_tip + d/2 for any rod the tip can push in one sample. */
#define FW_WIRE_PUSH_STEPS_MAX 64
/* Trenches: the rod's pieces (bits of fw_wire_t.held) and the largest
 * hold, 16.16 (the simulator's cap of 1000). */
#define FW_WIRE_PIECES 32
#define FW_WIRE_HOLD_ONE_Q16 ((int32_t)1 << 16)
#define FW_WIRE_HOLD_MAX_Q16 ((int32_t)1000 << 16)

/* fw_wire_t.flags */
#define FW_WIRE_PUSHED   (1u << 0)   /* moved by the tip in the last update */
#define FW_WIRE_SQUEEZED (1u << 1)   /* the tip squeezed it in the last update (section 7): it stayed */
#define FW_WIRE_RIDDEN   (1u << 3)   /* the tip rode over it in the last update (eq. 30, the load too small): it stayed */
#define FW_WIRE_SAT_POS  (1u << 2)   /* a move was clamped to int32 (sticky) */
#define FW_WIRE_RIDE_PENDING (1u << 4) /* eq. 30 predicts a ride-over the signals have not yet decided: it stays */

/* fw_wire_t.judge: the contact's ride-over judgement (above) */
#define FW_WIRE_JUDGE_NONE 0   /* undecided (or no contact) */
#define FW_WIRE_JUDGE_PUSH 1   /* the signals contradicted eq. 30's ride-over: the tip pushes it */
#define FW_WIRE_JUDGE_RIDE 2   /* the tip rides over it: declared, latched until the contact ends */
/* The climb's least threshold, pm (a rod thinner than 16 / 3 of it still needs it). */
#define FW_WIRE_CLIMB_FLOOR_PM 2000

typedef enum {
    FW_WIRE_TRANSLATE = 0,      /* l = L/2 exactly: S undefined */
    FW_WIRE_ROTATE_NEAR_B = 1,  /* l < L/2: S in [L/sqrt2, L] */
    FW_WIRE_ROTATE_NEAR_A = 2   /* l > L/2: S in [0, (1 - 1/sqrt2) L] */
} fw_wire_regime_t;

typedef struct {
    fw_wire_regime_t regime;
    bool s_defined;          /* false at the bifurcation */
    int32_t s_pm;            /* static point from A (0 when undefined) */
    q30_t k;                 /* F_min / (f L), 2.30, in [0.414, 1] (a held rod: min(k_q16, 1)) */
    int32_t k_q16;           /* F_min / (f L), 16.16: k, or up to FW_WIRE_HOLD_MAX for a held rod */
    q30_t u;                 /* (2l - L) / L, 2.30 */
    int32_t lever_pm;        /* |l - s| = sqrt(Q) >= L/2 */
} fw_wire_static_t;

/* Static point and minimum push. FW_ERR_ARG: L <= 0 or > 2^30 pm;
 * FW_ERR_DOMAIN: l outside [0, L].
 * Scaling and overflow: u = (2l - L) 2^30 / L (< 2^61); sqrt(u^2 + 1) in
 * 2.30 (<= sqrt2); k = 2^60 / (sqrt(u^2 + 1) + |u|) in 64 bits; s and sqrt(Q)
 * = L sqrt(u^2 + 1) / 2 rounded to pm. Errors (test_wire sweep): k within
 * 2 LSB, s within 1 pm. */
fw_status_t fw_wire_static_point(int32_t length_pm, int32_t l_pm, fw_wire_static_t *out);

/* The static point with the rod's held pieces (above, "Trenches"): held
 * = 0 or hold_q16 = 1.0 is fw_wire_static_point exactly. Else the torque
 * balance G(s) = sum_k w_k int_piece sign(x - s) (x - l) dx = 0 (w_k =
 * hold or 1) is solved by bisection on the side of l where G changes sign
 * (G rises to l and falls after it, so the root is unique); G(0) = 0 is the
 * bifurcation (translate, s undefined, u = 0). k_q16 = |net friction| /
 * (f L) (a translation: the whole friction); u is the u a uniform rod
 * would have with S as far from its nearest end (so fw_wire_push's blend
 * to translation weighs how close S has come to an end, as on a uniform
 * rod); lever_pm = |l - s| but at least L/16: a push on a held piece has
 * its pivot close by, and the clamp bounds the turn (such a push needs
 * about hold times f L anyway).
 * Errors: as fw_wire_static_point; FW_ERR_ARG for hold_q16 below 1.0 or
 * above FW_WIRE_HOLD_MAX_Q16.
 * Scaling and overflow: positions in 16.16 fractions of L (pieces of
 * 2^11); a piece's doubled moment (b - a)(a + b - 2l) < 2^29 times w <=
 * 2^26, summed over 32 pieces: < 2^60; s to 1/65536 of L, rounded to pm;
 * u from S's distance to its nearest end (held_blend_u: 2^60 / m, m in
 * 2.30).
 * Errors (test_wire_trench, against the balance solved on the host for l
 * rounded to L / 65536, as here: s moves by net / (2 w(s) |s - l|) per
 * unit of l, large where S lies outside the held pieces): s within 2 L /
 * 65536; k within 10^-4 of it plus 4 w(s) / 65536, w(s) the
 * density at S (k's slope in s is 2 w(s)). */
fw_status_t fw_wire_static_point_held(int32_t length_pm, int32_t l_pm, uint32_t held, int32_t hold_q16,
                                      fw_wire_static_t *out);

/* Push force needed to move the rod: k(l) f L, pN (f L = friction of the
 * whole rod, eq. 23-24: mu_os (F_r,os + F_a,os) + tau_os A), saturated. */
int32_t fw_wire_push_threshold_pn(q30_t k, int32_t friction_fl_pn, bool *sat);

typedef struct {
    int32_t x_pm;            /* centre, frame A */
    int32_t y_pm;
    fw_bam_t psi;            /* axis direction A -> B */
    int32_t length_pm;
    int32_t diameter_pm;
    uint32_t flags;          /* FW_WIRE_* */
    uint32_t held;           /* bit k: piece k from A lies in a trench (fw_wire_hold); 0 after init */
    int32_t hold_q16;        /* friction across / along where held, 16.16 (fw_wire_tip_t.hold_q16) */
    /* what held was computed for (fw_wire_hold's cache) */
    int32_t hold_at_pm[2];
    fw_bam_t hold_at_psi;
    int32_t hold_points;     /* trench points seen; -1: never computed */
    int32_t axis_z_pm;       /* the axis's height above the substrate plane: d/2 on the flat, less (negative
                              * below the surface) once settled in a groove (fw_wire_settle) */
    /* the ride-over judgement (above): the contact under way */
    int32_t judge;           /* FW_WIRE_JUDGE_* */
    bool touching;           /* the apex touched it in the last update */
    bool z_ref_valid;        /* z_ref_pm holds a height */
    int32_t z_ref_pm;        /* the apex's height at the last sample off the rod, pm */
    int32_t snap_pm[2];      /* the rod's centre when the contact began, pm */
    fw_bam_t snap_psi;       /* and its direction */
    int32_t contact_moved_pm; /* the normal moves made in this contact, summed, pm (saturated) */
} fw_wire_t;

/* The first rule a rod breaks: length outside (0, 2^30] pm, diameter
 * <= 0, or a rod shorter than it is thick (FW_RULE_WIRE). */
fw_rule_t fw_wire_check(int32_t length_pm, int32_t diameter_pm);

/* Validates with fw_wire_check (FW_ERR_ARG also for a NULL w). */
fw_status_t fw_wire_init(fw_wire_t *w, int32_t x_pm, int32_t y_pm, fw_bam_t psi,
                         int32_t length_pm, int32_t diameter_pm);

/* The rod from end A to end B (frame A, pm): centre (A + B) / 2 (floor),
 * psi = atan2(B - A), L = round(|B - A|). FW_RULE_WIRE (and its status)
 * when L is 0 or above 2^30 pm or d <= 0. Scaling and overflow: B - A in
 * 64 bits (< 2^33), halved (floor) together for the angle until both fit
 * int32; |B - A|^2 < 2^65 would overflow: the length is taken of the
 * halved difference when it was halved (one LSB lost, doubled back). */
fw_status_t fw_wire_init_ends(fw_wire_t *w, const int32_t a_pm[2], const int32_t b_pm[2], int32_t diameter_pm);

/* The rod's ends A and B (frame A, pm) from its centre and psi, rounded,
 * saturated to int32. */
void fw_wire_ends_pm(const fw_wire_t *w, int32_t a_pm[2], int32_t b_pm[2]);

/* Push at l (from A) by dn pm along the normal n = (-sin psi, cos psi).
 * |dn| must be <= L/4 and <= the lever |l - s| (FW_ERR_DOMAIN: split larger
 * moves, the update is first order; the lever keeps dpsi within 1 rad); l outside [0, L] is FW_ERR_DOMAIN; dn = 0 leaves the wire
 * unchanged. *info (may be NULL) receives the static point used.
 * Scaling and overflow: dpsi = w dn 2^30 / sqrt(Q) in 2.30 (|dn| 2^30 <
 * 2^60), converted to fw_bam_t; centre step from the ratio
 * (L - 2s) / (2l - 2s) in 2.30; positions saturated (flag). */
fw_status_t fw_wire_push(fw_wire_t *w, int32_t l_pm, int32_t dn_pm, fw_wire_static_t *info);

/* Shift by (dx, dy) pm (drift), saturated (FW_WIRE_SAT_POS). */
void fw_wire_shift(fw_wire_t *w, int32_t dx_pm, int32_t dy_pm);

/* Where the apex stands against the rod. With the rod's axis through its
 * centre along psi and the normal n = (-sin psi, cos psi):
 *   l  = projection of the apex on the axis, from end A (pm)
 *   dn = the normal move of the rod that brings the apex (a circle of radius
 *        reach = r_tip + d/2 around the axis) to the rod's surface:
 *        normal + reach when the apex is on the -n side (dn > 0: the rod is
 *        pushed along +n), normal - reach on the +n side.
 * *touch: 0 <= l <= L and |normal| < reach (ends are flat: the rod's
 * footprint is a rectangle). When *touch is false, *l_pm and *dn_pm are
 * still set. FW_ERR_ARG on NULL or reach < 0.
 * Scaling and overflow: offsets in 64 bits (|d| < 2^33 pm); projections
 * d x (2.30) < 2^64 would overflow for |d| >= 2^33: never, as both
 * positions are int32; >> 30 rounded; l and dn saturated to int32. */
fw_status_t fw_wire_contact(const fw_wire_t *w, const int32_t tip_pm[2], int32_t reach_pm, bool *touch,
                            int32_t *l_pm, int32_t *dn_pm);

/* ---- tip-substrate-wire squeeze (section 7, eq. 29-30) -------------------
 *   F_r = k (mu F_a,os + tau A) / (cos psi - k mu sin psi)          (29)
 *       = k FL / (sqrt(1 + (k mu)^2) sin(psi_max - psi)),
 *   psi_max = atan(1 / (k mu))
 *   dF = F_r sin psi - F_a,ts                                       (30)
 * The second form is exact and keeps the small denominator accurate.
 * psi >= psi_max: the tip squeezes the wire: FW_ERR_DOMAIN, flag
 * FW_FLAG_SQUEEZE, F_r = dF = INT32_MAX. Below psi_max F_r saturates to
 * INT32_MAX (flag FW_FLAG_SAT_FORCE) before it overflows; push_pn =
 * F_r cos psi (with the same saturation; INT32_MAX past psi_max). */
typedef struct {
    fw_bam_t psi_max;
    int32_t f_r_pn;          /* F_r (29) */
    int32_t push_pn;         /* its horizontal part F_r cos psi: the lateral force that moves the rod */
    int32_t df_pn;           /* (30) */
    uint32_t flags;
} fw_squeeze_t;

/* psi in [0, 90 deg), k in (0, 1] (2.30), mu in [0, 2) (2.30), FL >= 0,
 * F_a,ts >= 0 (pN); FW_ERR_ARG otherwise.
 * Scaling and overflow: k mu in 2.30 (< 2); sqrt(1 + (k mu)^2) in 2.30
 * from a 4.60 argument (< 2^63); denominator in 2.30 (64 bits); F_r = k FL / den with a
 * 2.30 x pN numerator (< 2^62); saturated. */
fw_status_t fw_wire_squeeze_solve(fw_bam_t psi, q30_t k, q30_t mu, int32_t friction_fl_pn,
                                  int32_t adhesion_ts_pn, fw_squeeze_t *out);

/* ---- the push rule (per sample) ------------------------------------------ */

/* What a push of every rod shares: the tip and the substrate. */
typedef struct {
    int32_t tip_radius_pm;           /* r_tip */
    fw_bam_t tip_half_angle;         /* gamma, the cone's half angle */
    int32_t friction_pn_per_um;      /* f: wire-substrate friction per length */
    q30_t mu;                        /* wire-substrate mu (eq. 29), [0, 2) */
    int32_t adhesion_ts_pn;          /* F_a,ts: tip-substrate adhesion (eq. 30) */
    bool down_force;                 /* the cone presses the rod (eq. 29): false after fw_wire_tip_init */
    int32_t hold_q16;                /* a trench's hold (above, "Trenches"), 16.16, in [1, 1000] */
} fw_wire_tip_t;

/* The first rule broken: f < 0 or mu outside [0, 2) (FW_RULE_WIRE_FRICTION);
 * r_tip outside [0, 2^30] (FW_RULE_TIP_RADIUS); gamma outside (0, 60 deg)
 * (FW_RULE_TIP_HALF_ANGLE); F_a,ts < 0 (FW_RULE_ADHESION). */
fw_rule_t fw_wire_check_tip(int32_t tip_radius_pm, int32_t tip_half_angle_mdeg, int32_t friction_pn_per_um,
                            int32_t mu_ppm, int32_t adhesion_ts_pn);

/* Fills tip after fw_wire_check_tip (its rule's status); down_force is
 * false (set it after init to model the cone's down force). hold_q16 =
 * cos(gamma - beta) / (mu sin(gamma - beta)), beta = atan(mu), capped
 * to [1, 1000]; FW_WIRE_HOLD_MAX_Q16 when gamma - beta < 1 mrad.
 * Scaling and overflow: cos 2^46 / (sin mu >> 30), both 2.30: < 2^47 over
 * at least 1 (a quotient above the cap is capped before it is narrowed). */
fw_status_t fw_wire_tip_init(fw_wire_tip_t *tip, int32_t tip_radius_pm, int32_t tip_half_angle_mdeg,
                             int32_t friction_pn_per_um, int32_t mu_ppm, int32_t adhesion_ts_pn);

/* Which of the rod's pieces the trenches hold (above, "Trenches"), into
 * w->held, with w->hold_q16 = tip->hold_q16. pts: fw_litho's record, n of
 * them (a point flagged FW_LITHO_STROKE_START begins a new polyline; NULL
 * or n <= 0: nothing is held). Cached: recomputed only when the rod's
 * pose or the number of points changed since the last call.
 * Scaling and overflow: segments with a coordinate difference from the
 * rod's centre or a length of 2^30 pm or more are skipped (they hold
 * nothing a rod of at most 2^30 pm reaches: width < 2^31); the rest in 64
 * bits: each product < 2^61 and their sums < 2^62, the parameter along a
 * segment in 2.30. */
fw_status_t fw_wire_hold(fw_wire_t *w, const fw_wire_tip_t *tip, const fw_trench_point_t *pts, int32_t n);

/* A rod settles into a trench (physics.md section 9, "rods sink into
 * trenches"; the simulator's World::settle_rods is the truth it is judged
 * against): when at least half of FW_WIRE_SETTLE_POINTS points along its
 * axis lie over a V at least as wide as the rod (within half the recorded
 * width of a piece of the trench's path, projected inside that piece), it
 * slides down the walls onto the path. Each such point k (u_k = 2k + 1 - K
 * along the rod) has its target T_k, the point moved across the groove
 * onto the path; the rod turns to the direction of the targets' line (the
 * regression of T on u: H sum u T - sum u sum T, fw_math_atan2_bam) and its
 * centre moves to its foot on that line through the targets' mean
 * (it never slides along the groove). It then rests on both walls: with
 * h = w/2 the V's half width at the surface under it (the recorded widths'
 * mean over the points), its axis lies at (R - h cos gamma) / sin gamma
 * above the substrate plane (negative: below it; that is -D + R / sin gamma
 * with D = h / tan gamma; w->axis_z_pm). The walls touch it below the
 * surface when h >= R cos gamma, which a groove that holds it (h >= R)
 * always meets. A rod not over a groove gets d/2 back.
 * pts, n: fw_litho's record as fw_wire_hold takes it; tip: gamma. Returns
 * true when the rod is seated in a groove. The card calls it after a sample
 * that pushed the rod.
 * Scaling and overflow: pieces with a coordinate difference from the rod's
 * centre or a length of 2^30 pm or more are skipped (as fw_wire_hold);
 * the point's cross product with a piece < 2^62, divided by the piece's
 * length (isqrt of < 2^61); the normal in 2.30 (< 2^30 |u| / |u|); each
 * target < 2^31 pm, so the sums over 17 points < 2^36, sum u T < 2^40
 * (|u_k| <= 16) and the direction's parts < 2^46; they are shifted right
 * together until both fit int32 for atan2; the centre's foot: a difference
 * < 2^32 times 2.30 < 2^62. A shift that would leave int32 saturates
 * (fw_wire_shift).
 * The seat: h < 2^30, R < 2^30, products with 2.30 cosines < 2^61; the
 * quotient by sin gamma (2.30), -D + R / sin gamma, is saturated to int32
 * (it fits while D and R / sin gamma stay under 2^30 pm, a millimetre);
 * a sin gamma of 0 (gamma = 0) leaves the axis at R. */
#define FW_WIRE_SETTLE_POINTS 17
bool fw_wire_settle(fw_wire_t *w, const fw_wire_tip_t *tip, const fw_trench_point_t *pts, int32_t n);

/* The rod's friction f L (pN): f (pN/um) L (pm) / 10^6, rounded.
 * Scaling and overflow: f < 2^31, L <= 2^30: the product < 2^61. */
int32_t fw_wire_friction_pn(const fw_wire_tip_t *tip, const fw_wire_t *w);

/* The ride-over judgement's thresholds for a rod of diameter d (pm; above):
 * the climb that declares a ride-over, max(3 d / 8, FW_WIRE_CLIMB_FLOOR_PM)
 * (3 d in 64 bits),
 * and how far past the apex's radius the apex must stand inside the reach,
 * with no climb and the push still on, to contradict eq. 30: d / 8. */
int32_t fw_wire_climb_on_pm(int32_t diameter_pm);
int32_t fw_wire_contra_extra_pm(int32_t diameter_pm);

/* One sample of the push rule (above): apex (frame A, pm: x, y and z, z the
 * z piezo's height, the ride-over's climb), the contact
 * force excess_pn (fw_force_lateral_excess_pn) and the lever's twist
 * theta_t (radians in 2.30, sign ignored: it tilts the cone away from the
 * rod), and the tip's load F_z (pN, the sample's measured normal force;
 * INT32_MAX: a load that never lets the tip ride over). Clears
 * FW_WIRE_PUSHED, FW_WIRE_SQUEEZED, FW_WIRE_RIDDEN and FW_WIRE_RIDE_PENDING,
 * then raises the one that happens; keeps the contact's judgement in w.
 * FW_ERR_ARG for a NULL pointer.
 * Scaling and overflow: fw_wire_contact, fw_wire_static_point,
 * fw_wire_push_threshold_pn (saturated; with the down force, push_pn of
 * fw_wire_squeeze_solve, saturated), psi = gamma + |theta_t| as a
 * binary angle (|theta_t| clamped to 90 deg), fw_wire_squeeze_solve,
 * H_ride (fw_wire_ride_push_pn), fw_wire_push steps of at most L/4; the
 * climb z - z_ref in 64 bits; the contact's moves summed saturated. */
fw_status_t fw_wire_update(fw_wire_t *w, const fw_wire_tip_t *tip, const int32_t apex_pm[3], int64_t excess_pn,
                           q30_t twist_rad, int32_t load_pn);

/* The most the tip can push horizontally through a contact at psi before
 * it lifts off the substrate, H_ride = (F_z + F_a,ts) / tan psi, pN (the
 * tip's vertical balance: the contact's vertical part H tan psi against
 * the load and the adhesion). 0 when F_z + F_a,ts <= 0.
 * Scaling and overflow: F_z + F_a,ts < 2^32 in 64 bits, times cos psi in
 * 2.30 < 2^62, divided by sin psi (2.30), saturated to int32 (a small psi
 * gives a large H_ride). psi is an unsigned binary angle: 0 gives
 * INT32_MAX (no flank to climb), 90 deg or more gives 0. */
int32_t fw_wire_ride_push_pn(fw_bam_t psi, int32_t load_pn, int32_t adhesion_ts_pn);

#endif /* FW_WIRE_H */
