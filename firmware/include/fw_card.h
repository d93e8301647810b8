/*
 * fw_card.h - the whole A/D card: one instance holding everything the card
 * does per DMA block (design.md, "The card").
 *
 * Per block (fw_card_step_block), for each sample of the block:
 *   1. the signal chain: acquisition, virtual S_n, compensation, direction
 *      of motion, force (eq. 1-3) in frame A; on the 32-bit data path
 *      (fw_board_step_block, the default) or the 16-bit one
 *      (fw_board16_step_block: word_bits 16, its error contract there);
 *   2. the object models, when the configuration has any and the tip was
 *      down for the block (the pose given with the previous block was
 *      engaged; the first block: not start_lifted; a lifted tip touches
 *      nothing, whatever the noise on its signals): the contact force
 *      (fw_force_lateral_excess_pn, once per sample for every model), the
 *      particles (fw_particles_update), each wire's push rule with the
 *      squeeze check (fw_wire_update; the lever's twist theta_t = K_l S_l),
 *      the lithography trenches (fw_litho_step);
 *   3. with the interlock on (interlock): the sample's normal force F_z and
 *      its lateral channel's F_y (eq. 1a from its code) against the
 *      limits, a saturated ADC counting as over (fw_guard_over_q23);
 * then, once per block: the block's mean force, flags and last apex, the
 * force on the operator's hand (haptic: gain and limit), and the command to
 * the piezo for the next block from the operator's pose given with the
 * block: the joystick target (fw_comp) moved by the drift the local scans
 * measured, less the bending offset of the block's last signals, then
 * shaped for the scanner when its compensation is on (creep_enable:
 * fw_creep; hyst_enable: fw_hyst's inverse; the configuration's fields
 * below). With either on, the apex each sample gives the object models is
 * where the scanner is: the sample's piezo reading (the drive) through the
 * direct hysteresis model, plus the creep the feed-forward expects of the
 * command (r - u of the command the samples were taken with), not the
 * drive itself. The command answers the pose of the block it is computed in: the haptic
 * loop's latency is one block, as a card's DMA with two buffers has it.
 * The interlock (fw_guard.h) then steps with the block's causes and the
 * pose (its load, the joystick target before the drift, its engagement):
 * latched (the block tripped, or an earlier one did and the operator's
 * set point has not moved away), the command retracts the tip (engaged
 * false, the xy set point as the pose asks) and the block carries
 * FW_FLAG_INTERLOCK. The next block's samples are taken with the command's
 * engagement (a retracted tip touches nothing: no object model runs).
 *
 * Between blocks, fw_card_fix applies a local scan's finding (physics.md
 * section 10): the object's scanned position against its model is drift
 * (fw_drift), accepted up to the drift limit (a landmark: the landmark
 * limit, taken whole as a jump), and the change of the drift estimate is
 * applied to every model; the command follows from the next block. With
 * the Kalman filter (drift_filter) the estimate also moves on at its
 * estimated velocity at each block's end, before the command, and every
 * model moves with it.
 *
 * Wires are rigid rods (fw_wire); the trenches the card has recorded
 * (fw_litho) hold them (fw_wire_hold before each sample's push rule: the
 * pieces of a rod that lie in a trench resist a push across it).
 *
 * A pure function of its inputs: the same configuration and the same
 * sequence of blocks and fixes give the same outputs, bit for bit (replay,
 * ./afm replay, is the proof). C99, fixed point, no heap, no I/O: all
 * storage is the caller's (fw_card_storage_t), and the arrays the
 * configuration points to must outlive the card (fw_card_reset reads them
 * again).
 *
 * Units: positions pm, frame A; forces pN (force of the sample on the tip);
 * haptic force uN; angles mdeg in the configuration.
 */
#ifndef FW_CARD_H
#define FW_CARD_H

#include "fw_types.h"
#include "fw_rules.h"
#include "fw_board.h"
#include "fw_board16.h"
#include "fw_particles.h"
#include "fw_wire.h"
#include "fw_litho.h"
#include "fw_drift.h"
#include "fw_guard.h"
#include "fw_hyst.h"
#include "fw_creep.h"

/* disp_n_pm_per_v, disp_l_pm_per_v of the board configuration: use the
 * lever's estimate 3 h K_n / (2 l) (fw_calib_disp_estimate). */
#define FW_CARD_DISP_ESTIMATE (-1)
/* Trench points are recorded every 5 nm of tip path (litho_step_pm 0). */
/* How deep inside an object it models the block's last apex must be, with
 * F_x unobservable and the tip engaged (a lifted tip over an object pushes
 * nothing), for the card to flag FW_FLAG_BLIND_PUSH (pm): a push it sees
 * keeps the apex at contact distance. */
#define FW_CARD_BLIND_DEPTH_PM 5000
#define FW_CARD_LITHO_STEP_DEFAULT_PM 5000
/* The operator's hand: 0.1 N per nN of tip force (100 uN/pN), at most 3 N
 * per axis (a Phantom-class device's peak force): values for a host without
 * a device model (the unit tests). The bench passes the scene's
 * operator.haptic (host/card_setup.cpp). */
#define FW_CARD_HAPTIC_UN_PER_PN_DEFAULT 100
#define FW_CARD_HAPTIC_MAX_UN_DEFAULT 3000000

typedef struct { int32_t id; int32_t x_pm; int32_t y_pm; int32_t radius_pm; } fw_card_particle_t;
typedef struct { int32_t id; int32_t a_pm[2]; int32_t b_pm[2]; int32_t diameter_pm; } fw_card_wire_t;   /* ends A, B */
typedef struct { int32_t id; int32_t x_pm; int32_t y_pm; } fw_card_landmark_t;

typedef struct {
    fw_board_config_t board;            /* the signal chain; disp_*: FW_CARD_DISP_ESTIMATE allowed */
    int32_t word_bits;                  /* the chain's data path: 32 (fw_board; 0 means 32) or 16 (fw_board16) */
    int32_t tip_radius_pm;              /* r_tip */
    int32_t tip_half_angle_mdeg;        /* gamma, the cone's half angle, (0, 60) deg */
    /* the cone's down force (sections 5-7): with it a push H presses what it
     * pushes by H tan psi, psi = gamma (+ the lever's twist for wires):
     * particles' thresholds (fw_particles_down_threshold_pn) and wires'
     * pushes (eq. 29) rise, and past psi_max the tip squeezes (flag
     * FW_FLAG_SQUEEZE). Without it F_down = 0 and nothing squeezes. */
    bool down_force;
    /* particles (section 5): F_th = mu_ps (F_adh,ps + F_down) + tau_ps A_c */
    const fw_card_particle_t *particles;
    int32_t n_particles;
    int32_t particle_mu_ppm;            /* mu_ps */
    int32_t particle_adhesion_pn;       /* F_adh,ps */
    int32_t particle_shear_kpa;         /* tau_ps */
    int32_t particle_contact_area_nm2;  /* A_c */
    int32_t particle_margin_pn;         /* contact margin above half the threshold (fw_particles) */
    /* wires (section 6-7) */
    const fw_card_wire_t *wires;
    int32_t n_wires;
    int32_t wire_friction_pn_per_um;    /* f */
    int32_t wire_mu_ppm;                /* wire-substrate mu (eq. 29) */
    /* lithography (section 9) */
    bool litho;
    int32_t litho_threshold_pn;
    q16_t litho_depth_pm_per_pn;        /* 16.16 */
    int32_t litho_step_pm;              /* 0: FW_CARD_LITHO_STEP_DEFAULT_PM */
    /* drift and landmarks (section 10) */
    int32_t drift_max_step_pm;          /* 0: FW_DRIFT_MAX_STEP_DEFAULT_PM */
    /* the drift estimate (fw_drift.h): FW_DRIFT_FILTER_STEP (0, the default)
     * or FW_DRIFT_FILTER_KALMAN with its parameters (period_us: the
     * block's period) and the variance it gives each local scan's
     * registration (nm^2, 16.16) */
    int32_t drift_filter;
    fw_kalman_params_t drift_kalman;
    q16_t drift_scan_var_nm2;
    int32_t landmark_max_step_pm;       /* > 0 when there are landmarks */
    const fw_card_landmark_t *landmarks;
    int32_t n_landmarks;
    /* the operator's hand */
    int32_t haptic_un_per_pn;           /* stylus force per tip force, uN/pN */
    int32_t haptic_max_un;              /* per axis, uN */
    bool start_lifted;                  /* the first block's samples were taken with the tip lifted */
    /* the force interlock (fw_guard.h); off: no limit is checked */
    bool interlock;
    int32_t interlock_normal_pn;        /* |F_z| above it trips: in (0, k_n K_n 10 V) */
    int32_t interlock_lateral_pn;       /* |F_y| above it trips: in (0, k_theta K_l / h 10 V) */
    /* the scanner's compensation, each off by default (a zeroed
     * configuration: the command is the piezo set point above, unshaped).
     * The command for the next block passes the creep feed-forward, then
     * the inverse hysteresis model (a scanner that creeps after its
     * hysteresis, y = C[H[u]], is inverted as u = H^-1[C^-1[r]]), x and y
     * each through its own instance. */
    bool creep_enable;
    fw_creep_params_t creep;            /* both axes; period_us: the block's period */
    bool hyst_enable;
    fw_hyst_params_t hyst[2];           /* x, y: the direct models ./afm calib scanner fits; the card inverts them */
} fw_card_config_t;

/* The caller's storage: capacities at least the configuration's counts
 * (particles and wires may be NULL when there are none; trench points are
 * needed only with lithography); a sample scratch of any length >= 1
 * (longer blocks are run in pieces). */
typedef struct {
    fw_particle_t *particles;
    int32_t particle_capacity;
    fw_wire_t *wires;
    int32_t wire_capacity;
    fw_trench_point_t *trench;
    int32_t trench_capacity;
    fw_sample_out_t *scratch;
    int32_t scratch_len;
} fw_card_storage_t;

/* The operator's pose for a block (HAPTIC_POSE). */
typedef struct {
    int32_t joy_q15[2];   /* stylus x, y, 1.15 (clamped to [-1, 1 - 2^-15]) */
    int32_t load_pn;      /* normal load set point, pN */
    bool engaged;         /* tip in contact under z feedback */
} fw_card_pose_t;

typedef struct {
    const fw_sample_in_t *samples;   /* the DMA block */
    int32_t n;                       /* samples, >= 0 */
    fw_card_pose_t pose;
} fw_card_in_t;

typedef struct {
    int32_t force_pn[3];     /* mean over the block, frame A, rounded half away from zero (0 for n = 0) */
    uint32_t flags;          /* OR of the block's sample flags (FW_FLAG_*) */
    int32_t code_n;          /* the block's last ADC codes */
    int32_t code_l;
    int32_t tip_pm[3];       /* the block's last apex estimate, frame A */
    int32_t target_pm[2];    /* the apex target of the pose, frame A, drift included */
    int32_t piezo_cmd_pm[2]; /* piezo xy set point for the next block */
    int32_t load_pn;         /* the pose's load and engagement, passed on */
    bool engaged;
    int32_t haptic_un[3];    /* force on the stylus, frame A axes, uN, clamped to +-haptic_max_un */
    uint32_t sat_samples;    /* samples with S_n or S_l saturated since reset (saturating) */
    fw_guard_state_t interlock; /* the interlock's step for this block (FW_GUARD_ARMED when off);
                                   TRIPPED, HOLDING: engaged is false and flags hold FW_FLAG_INTERLOCK */
} fw_card_out_t;

typedef enum {
    FW_CARD_FIX_APPLIED = 0,       /* the difference was drift: every model moved (fw_card_place: that particle moved) */
    FW_CARD_FIX_UNKNOWN_OBJECT,    /* no particle or landmark has that id: nothing done */
    FW_CARD_FIX_NOT_DRIFT          /* further than the limit: refused, counted (fw_drift) */
} fw_card_fix_result_t;

typedef struct {
    fw_card_fix_result_t result;
    bool landmark;           /* the object is a landmark */
    int32_t model_pm[2];     /* its modelled position before the fix */
    int32_t delta_pm[2];     /* the correction applied (0 unless applied) */
} fw_card_fix_out_t;

typedef struct {
    fw_card_config_t cfg;            /* as given (disp_* as given) */
    fw_card_storage_t st;
    fw_board_t board;                /* its configuration holds the displacement constants used */
    fw_board16_t board16;            /* the 16-bit chain, when chain16 */
    bool chain16;
    fw_particles_t parts;
    int32_t n_wires;
    fw_wire_tip_t wire_tip;
    q30_t twist_rad_per_v;           /* K_l = 3 K_n / (2 l), rad/V in 2.30 (the squeeze's theta_t) */
    fw_litho_t litho;
    fw_drift_t drift;
    fw_guard_t guard;                /* the interlock, when cfg.interlock */
    fw_creep_t creep[2];             /* x, y, when cfg.creep_enable */
    fw_hyst_t hyst[2];               /* x, y, when cfg.hyst_enable */
    int32_t creep_expect_pm[2];      /* the creep the feed-forward took off the last command (r - u), pm */
    bool objects;                    /* particles, wires or lithography: the per-sample models run */
    bool down;                       /* this block's samples were taken with the tip engaged */
    uint32_t sat_samples;
    uint32_t fixes_applied;
    int32_t last_tip_pm[3];
    int32_t last_code_n;
    int32_t last_code_l;
} fw_card_t;

/* The first rule the configuration or storage breaks, module by module:
 * the chain's word (FW_RULE_WORD_BITS), the board (fw_board_check, or
 * fw_board16_check for 16 bits, with the displacement estimate where asked),
 * particles (fw_particles_check, each particle's, capacity), wires (each
 * rod's fw_wire_check, fw_wire_check_tip, capacity), lithography
 * (fw_litho_check, storage), drift (fw_drift_check, fw_drift_filter_check), landmarks (capacity),
 * haptic (gain and limit >= 0), the interlock's limits when it is on
 * (fw_guard_check, against the board's gains), the creep law and each
 * axis's hysteresis model when on (fw_creep_check, fw_hyst_check). FW_RULE_NULL_POINTER for NULL arguments,
 * a NULL array with a count > 0, or no scratch. */
fw_rule_t fw_card_check(const fw_card_config_t *cfg, const fw_card_storage_t *st);

/* Validates with fw_card_check; on FW_RULE_OK sets the card up and resets
 * it. Returns the rule's status (FW_OK when none is broken) and the rule
 * in *rule (may be NULL): the rule the configuration breaks, by name
 * (fw_rule_text). On failure the card is unusable. */
fw_status_t fw_card_init(fw_card_t *c, const fw_card_config_t *cfg, const fw_card_storage_t *st,
                         fw_rule_t *rule);

/* Back to the state after init: the signal chain, the objects at their
 * configured places, no trenches, no drift, the interlock not latched,
 * counters zero. */
void fw_card_reset(fw_card_t *c);

/* One DMA block (above). FW_ERR_ARG (nothing done) for a NULL pointer or
 * n < 0, or samples NULL with n > 0. */
fw_status_t fw_card_step_block(fw_card_t *c, const fw_card_in_t *in, fw_card_out_t *out);

/* A local scan found object_id at scan_pm (frame A): above. FW_ERR_ARG
 * for a NULL pointer; otherwise FW_OK with the result in *out. */
fw_status_t fw_card_fix(fw_card_t *c, int32_t object_id, const int32_t scan_pm[2], fw_card_fix_out_t *out);

/* A local scan found particle object_id at scan_pm (frame A) after a push
 * the model followed imperfectly: its model alone is put there (the
 * drift and every other model stay). The same limit as a drift fix
 * (drift_max_step_pm: a model that far off is not this particle's): beyond
 * it FW_CARD_FIX_NOT_DRIFT, nothing moves, counted as fw_drift's refusals;
 * a landmark or an unknown id is FW_CARD_FIX_UNKNOWN_OBJECT. Counted with
 * the fixes applied. FW_ERR_ARG for a NULL pointer; otherwise FW_OK with
 * the result in *out. Scaling and overflow: fw_drift_within's; the
 * position is the scan's, no arithmetic. */
fw_status_t fw_card_place(fw_card_t *c, int32_t object_id, const int32_t scan_pm[2], fw_card_fix_out_t *out);

/* The models, read-only, for the host to publish. */
const fw_particles_t *fw_card_particles(const fw_card_t *c);
int32_t fw_card_wire_count(const fw_card_t *c);
const fw_wire_t *fw_card_wire(const fw_card_t *c, int32_t i);     /* NULL outside [0, count) */
int32_t fw_card_wire_id(const fw_card_t *c, int32_t i);          /* 0 outside [0, count) */
const fw_litho_t *fw_card_litho(const fw_card_t *c);             /* NULL without lithography */
void fw_card_drift_pm(const fw_card_t *c, int32_t offset_pm[2]);  /* accumulated drift, frame A */
uint32_t fw_card_fixes_applied(const fw_card_t *c);
/* The interlock (limits, latch, trips); NULL when it is off. */
const fw_guard_t *fw_card_guard(const fw_card_t *c);
/* The displacement constants in use (the estimate, or as configured). */
int32_t fw_card_disp_n_pm_per_v(const fw_card_t *c);
int32_t fw_card_disp_l_pm_per_v(const fw_card_t *c);

#endif /* FW_CARD_H */
