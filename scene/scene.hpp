// The scene: what a run simulates, displays and writes. Parsed from YAML by
// yaml-cpp and validated here, in one place, for every process of a run.
//
// Units are in the key names (nm, nN, s, Hz, deg, N_per_m, ...). Every
// number is held to its row of one table, kSceneRanges (scene_ranges.hpp).
// A bad scene raises SceneError with one line: "<file>: <key>: <what is
// wrong> (value)".
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

extern "C" {
#include "fw_paper_probe.h"
}

#include "gsf.hpp"
#include "process.hpp"

namespace afm {

// A scene the bench refuses, said in one line naming the file, key and value
// (an input error: exit 2, process.hpp).
class SceneError : public InputError {
public:
    using InputError::InputError;
};

struct Vec2 { double x = 0, y = 0; };

// Distance from p to the segment [a, b] (a point when a == b), in the units given.
double point_segment_distance(Vec2 p, Vec2 a, Vec2 b);

// The scanner's range (physics.md section 12: 90 um x 90 um, 5 um in z),
// about its centre, the origin of frame A. The validator keeps the field
// inside it; the simulator clamps set points to it.
constexpr double kScannerRangeXY_nm = 90000.0;
constexpr double kScannerRangeZ_nm = 5000.0;

// Defaults: the paper's lever (firmware/include/fw_paper_probe.h, the one
// definition), in the scene's units.
struct ProbeSpec {
    double spring_N_per_m = FW_PAPER_KN_MN_PER_M * 1e-3;                  // normal spring constant k_n
    double deflection_nm_per_V = FW_PAPER_DEFLECTION_PM_PER_V * 1e-3;     // normal gain K_n: deflection per volt of S_n
    double lateral_nN_per_V = FW_PAPER_LATERAL_GAIN_PN_PER_V * 1e-3;      // k_theta K_l / h (lateral calibration)
    double lever_length_um = FW_PAPER_LEVER_LENGTH_NM * 1e-3;             // l
    double tip_height_um = FW_PAPER_TIP_HEIGHT_NM * 1e-3;                 // h
    double tip_radius_nm = 10.0;        // apex radius
    double tip_half_angle_deg = 20.0;   // cone half angle gamma
    double scan_angle_deg = 270.0;      // 270: frames C and A coincide
    // The real lever's displacement constants: the apex's move per volt of
    // S_n (along the lever) and of S_l (across), nm/V. The simulator's
    // truth; none: the beam's 3 h K_n / (2 l) (the firmware's estimate).
    std::optional<double> cn_nm_per_V, cl_nm_per_V;
};

// The card's calibrated constants (firmware.*): what a lab measured and
// flashed. None: the firmware's estimate (C_n, C_l) or the probe's value.
struct FirmwareCalibration {
    std::optional<double> disp_n_nm_per_V, disp_l_nm_per_V;   // C_n, C_l
    std::optional<double> lateral_nN_per_V;                   // k_theta K_l / h
    std::optional<double> mu;                                 // tip-substrate mu for the F_x fallback
    // The card's drift correction limit (fw_drift): a local scan's finding
    // further from its model than this is refused. None: the firmware's
    // FW_DRIFT_MAX_STEP_DEFAULT_PM (200 nm). Local scans that miss their
    // object scan again wider, out to this limit.
    std::optional<double> drift_max_step_nm;
    // The card's drift estimate (fw_drift.h): "step" (each local scan's
    // offset taken whole and held) or "kalman" (fw_kalman: constant
    // velocity and a random walk, predicting between scans), and the
    // filter's figures as the card takes them (firmware.drift_*; none: the
    // card's nominal, host/card/card_table.cpp): the walk, the velocity's
    // prior sigma and a local scan's registration sigma.
    std::string drift_filter = "step";
    std::optional<double> drift_walk_nm_per_sqrt_min, drift_rate_nm_per_min, drift_scan_sigma_nm;
    // The card's force interlock (firmware/include/fw_guard.h): on unless
    // firmware.interlock is false (a lab turns it off to press past the
    // lever's range on purpose, as the paper's deep lines do). Its limits
    // (firmware.interlock_normal_nN, firmware.interlock_lateral_nN, > 0 and
    // below the channel's full scale, the card's rule); none: 80 % of the
    // channel's full scale (fw_guard_default_limit_pn).
    bool interlock = true;
    std::optional<double> interlock_normal_nN, interlock_lateral_nN;
    // The card's own values of the lever, the tip and the sample: a
    // datasheet's or a lab's measurement (firmware.*). None: the card's
    // nominal (host/card/card_table.cpp), never the probe's or the
    // sample's: those are the simulator's truth.
    std::optional<double> spring_N_per_m, deflection_nm_per_V, lever_length_um, tip_height_um;
    std::optional<double> tip_radius_nm, tip_half_angle_deg;
    std::optional<double> adhesion_nN;                        // tip-substrate pull-off
    std::optional<double> particle_mu, particle_adhesion_nN, particle_shear_strength_MPa, particle_contact_area_nm2;
    std::optional<double> wire_friction_nN_per_um, wire_mu;
    std::optional<double> litho_threshold_nN, litho_depth_nm_per_nN;
    // What a calibration on the bench measured (firmware.calibration,
    // written by analysis/card_calib.py): its run's id and its results. The
    // card takes them where the scene's own firmware.* leaves a value out.
    struct Bench {
        std::string run;                                      // the calibration's id ("tilted fnv1a64:...")
        std::optional<double> mu, lateral_nN_per_V, disp_n_nm_per_V;
    };
    std::optional<Bench> calibration;
    // The scanner's compensation (fw_card.h: hyst_enable, creep_enable; both
    // off unless given). The direct hysteresis model of each axis, x and y,
    // as ./afm calib scanner fitted it from scans of a grating
    // (firmware.scanner, written into an include; analysis/scanner_calib.py):
    // thresholds r_nm (0 first, increasing) and weights w, one per play. The
    // creep law's gamma (% of a step a decade) and t0 (s): the scanner's
    // datasheet or a lab's step test (firmware.creep_*; none: the card's
    // nominal). Never the scene's afm.hysteresis or afm.creep (the truth).
    bool hyst_enable = false, creep_enable = false;
    struct ScannerAxis {
        std::vector<double> r_nm, w;
    };
    struct Scanner {
        std::string run;                                      // the calibration's id ("scanner fnv1a64:...")
        ScannerAxis axis[2];                                  // x, y
    };
    std::optional<Scanner> scanner;
    std::optional<double> creep_gamma_pct_per_decade, creep_t0_s;
};

// The checks of a run's verdict (host/launch/verdict.hpp), the names
// a scene's expect: may give.
inline const std::vector<std::string> &verdict_checks()
{
    static const std::vector<std::string> k{"fidelity", "assembly", "interlock", "saturation", "unobservable_push", "solver"};
    return k;
}

struct ContactSpec {                    // friction and adhesion of a material pair
    double mu = 0.1;                    // Coulomb friction coefficient
    double adhesion_nN = 0.0;           // pull-off (adhesion) force
    double shear_strength_MPa = 0.0;    // interfacial shear strength tau
    double contact_area_nm2 = 0.0;      // real contact area A_c
};

struct ParticleSpec { int id = 0; double x_nm = 0, y_nm = 0, radius_nm = 50; };

// Particles scattered at random (objects.scatter): count of them in a
// rectangle, no two closer than min_gap_nm surface to surface (nor that
// close to a wire or a landmark); the ids follow the listed particles' and
// landmarks'. Drawn with the bench's own generator (scene.cpp), the same
// on every machine.
struct ScatterSpec {
    int count = 0;
    double radius_nm = 50;
    Vec2 lo_nm, hi_nm;                  // the rectangle's corners
    double min_gap_nm = 100;
    uint64_t seed = 1;
};

// Where the planner puts particles (objects.targets): a list of sites (each
// [x, y], or {x_nm, y_nm, particle} pinned to that particle), or
// a text or a PNG mask rasterised into sites at pitch_nm
// (host/pattern.hpp).
struct TargetSpec {
    std::vector<Vec2> sites_nm;
    std::vector<int> pinned;            // per listed site: the particle id that must go there, -1: any (same length as sites_nm)
    std::string text;                   // rasterised with a Hershey font (OpenCV)
    std::string png;                    // a mask: dark pixels are the pattern (path relative to the scene)
    double pitch_nm = 300;              // spacing of the sites
    double height_nm = 2000;            // text: the letters' height; png: the mask's height
    Vec2 center_nm;                     // the pattern's centre
    bool any() const { return !sites_nm.empty() || !text.empty() || !png.empty(); }
};

// A rod's target pose (objects.wire_targets).
struct WireTargetSpec { int id = 0; double x_nm = 0, y_nm = 0, angle_deg = 0; };

// A nanowire lying on the substrate, from end A (x0, y0) to end B (x1, y1).
struct WireSpec { int id = 0; double x0_nm = 0, y0_nm = 0, x1_nm = 0, y1_nm = 0, diameter_nm = 100; };

// A landmark (section 10): a large fixed feature (a square pillar) that no
// push moves; a scan around it re-registers the work space, e.g. after a
// cantilever change. Its id shares the particles' id space.
struct LandmarkSpec { int id = 0; double x_nm = 0, y_nm = 0, side_nm = 500, height_nm = 200; };

// A cantilever change (section 10): the new lever sits somewhere else over
// the sample, so the whole work space jumps by offset_nm (only the simulator
// knows by how much; a landmark scan finds out).
struct CantileverChangeSpec { double at_s = 0; Vec2 offset_nm; };

// How wires sit on the substrate and how finely the simulator resolves them.
struct WireModelSpec {
    double friction_nN_per_um = 20.0;   // f: wire-substrate Coulomb friction per length (f L = physics.md eq. 23)
    double youngs_modulus_GPa = 83.0;   // E (silver); EI = E pi d^4 / 64 (wire_flexibility)
    int segments = 32;                  // N: segments of a flexible wire (wire_flexibility)
    int friction_points = 64;           // K: points integrating a rigid rod's friction where a trench holds part of it (uniform friction: exact, K unused)
    int relax_sweeps = 8;               // Newton-IRLS iterations of a flexible wire's step per sample (>= 8)
    double mu = 0.3;                    // mu_os: wire-substrate friction coefficient (the down force's friction, eq. 23; how firmly a trench holds a rigid wire)
    // Load-dependent friction (eq. 23-24): given adhesion_nN_per_um (F_a,os
    // per length), f = mu_os F_a,os / L + tau_os A / L, with A the contact
    // area from the wire's diameter by the named contact model (contact:
    // hertz_line, a cylinder on a flat under its adhesion; none: A = 0), and
    // friction_nN_per_um is derived (giving both is an error). The down
    // force F_r adds mu_os F_r on top while the tip pushes (effect
    // down_force). Scene::wire_friction_nN_per_um() is the one owner.
    std::optional<double> adhesion_nN_per_um;
    double shear_strength_MPa = 0.0;    // tau_os
    std::string contact = "hertz_line"; // hertz_line or none
    // How the simulator moves a rigid rod of uniform friction: "closed_form"
    // (eq. 20, integrated exactly: fast, and the card's own model) or
    // "numeric" (the friction lumped on friction_points points along the rod
    // and the least-dissipation balance solved by iteration: a truth
    // independent of the card's closed forms). A trench always takes the
    // numeric path.
    std::string solver = "closed_form";
};

// Nanolithography on polycarbonate (physics.md section 9).
struct LithoSpec {
    double threshold_nN = 20.0;         // load below which the tip removes nothing
    double depth_nm_per_nN = 2.0;       // depth = depth_nm_per_nN * (load - threshold)
};

// The instrument's errors (afm.hysteresis, afm.creep, afm.scan_artefacts,
// afm.z_drift), each acting only with its effect listed (piezo_hysteresis,
// piezo_creep, scan_artefacts, z_drift; physics.md section 17).
struct InstrumentSpec {
    double hysteresis_width_pct = 10.0;               // the loop's opening over its output range, for a cycle of span_nm
    double hysteresis_span_nm = kScannerRangeXY_nm;   // that cycle's peak-to-peak excursion (default: the scanner's range)
    double creep_pct_per_decade = 1.5;                // gamma: a step's creep per decade of time, % of the step
    double creep_t0_s = 0.1;                          // t0 of gamma log10(t / t0)
    double line_offset_rms_nm = 0.5;                  // scans: each line's height offset, rms
    double servo_lag_nm = 10.0;                       // scans: the z servo's first-order lag along the fast axis, as a length (tau v)
    double bow_sag_nm = 2.0;                          // scans: the scanner's bow, a parabola about the field's centre, this low at its edge
    double z_drift_nm_per_min = 1.0;                  // the deflection signal's zero: its drift rate, nm of deflection
    double z_drift_walk_nm_per_sqrt_min = 0.0;        // and its random walk
};

// A quick local scan around an object before an operation (section 10): the
// display replaces that region of the image and the firmware re-registers
// its models to where the scan finds the object (drift correction).
struct LocalScanSpec {
    double at_s = 0;                    // simulated time it is taken (at the first frame from then)
    int around_id = 0;                  // the particle or landmark it is centred on (its modelled position)
    double size_nm = 400;               // side of the scanned square
    // fix: drift (default): the particle's offset in the scan is the
    // sample's drift, and every model moves by it; place: the particle was
    // pushed since a scan last saw it, and only its model is put where the
    // scan shows it (a landmark's scan is always drift)
    bool place = false;
};

// The haptic device (a Phantom-class joystick) and the force the card
// renders on it (operator.haptic). It is updated once per block (block_hz:
// 1 kHz by default, a Phantom's servo rate); its axes are frame A's.
// The loop's stability bound is in host/card/haptic_bound.hpp.
struct HapticSpec {
    double half_range_mm = 80.0;        // stylus travel from the centre to the joystick's +-1 (a 160 mm workspace)
    double max_force_N = 1.4;           // the device's maximum continuous force, per axis (the card clamps to it)
    double max_stiffness_N_per_m = 3500.0;   // the stiffest spring the device can render (a Phantom Premium: 3.5 N/mm)
    // Force on the stylus per nN of tip force (the card's scaling, in 0.001
    // steps); none ("auto", the default): 4/5 of the largest gain inside the
    // stability bound (host/card/haptic_bound.hpp).
    std::optional<double> force_gain_N_per_nN;
    double damping_Ns_per_m = 3.0;      // the device's damping (mechanism and servo), N s/m
    bool passivity_check = true;        // refuse a scene outside the passivity bound (false: run, the controller clamps)
    // The stylus's third axis: the hand presses it down to set the load, the
    // load the pose asks for being load_span_nN x (depth / half_range) (0 at
    // the centre and above, load_span_nN at the stop), and feels F_z; 0: off
    // (the script or the page sets the load, z is not integrated).
    double load_span_nN = 0;
};

// The hand that holds the stylus (operator.hand): a spring-damper pulling it
// towards where the operator means it to be; the stylus and hand's mass.
struct HandSpec {
    double stiffness_N_per_m = 300.0;
    double damping_Ns_per_m = 8.0;
    double mass_kg = 0.15;
};

// A line the planner cuts before it pushes (operator.plan.cuts): the tip
// pressed at load_nN from `from` to `to` (lithography: a trench, e.g. the
// fixture a rod is pushed into, the paper's fig. 18).
struct CutSpec {
    Vec2 from_nm, to_nm;                // AFM frame
    double load_nN = 0;                 // above sample.lithography.threshold_nN
};

// The automatic planner (operator.plan): particles to objects.targets,
// rods to objects.wire_targets (host/planner.hpp).
struct PlanSpec {
    bool enabled = false;               // operator.plan is given
    double tolerance_nm = 25.0;         // a particle is placed within this of its target (checked by a scan)
    double speed_nm_per_s = 2000.0;     // pushing
    double travel_speed_nm_per_s = 10000.0;   // lifted, between pushes
    double scan_size_nm = 400.0;        // the local scans before and after each push
    int scan_px = 40;                   // pixels per line of a local scan
    double scan_s = 0.3;                // simulated time a local scan keeps the tip busy
    int max_pushes = 4;                 // attempts per object before it is reported unplaced
    double clearance_nm = 40.0;         // a push keeps this far from other particles' surfaces
    double push_depth_nm = 8.0;         // how far the tip aims into the particle it steers
    double approach_nm = 60.0;          // the tip lands this far behind the particle's surface
    double wire_tolerance_nm = 50.0;    // a rod's ends are placed within this of their targets
    double wire_step_nm = 120.0;        // the longest single end push of a rod
    std::vector<CutSpec> cuts;          // cut first, in order (needs the lithography effect)
};

struct OperatorSpec {
    double load_nN = 5.0;               // normal load while engaged
    // A load ramp (script and feel modes): the load rises (or falls) linearly
    // with simulated time from load_nN at 0 to this at duration_s; none: constant.
    std::optional<double> load_ramp_to_nN;
    std::optional<double> scan_load_nN; // the load scans are taken at (none: load_nN); a lithography run pushes hard and images light
    double speed_nm_per_s = 1000.0;     // apex speed along the path
    std::vector<Vec2> path_nm;          // waypoints, AFM frame; first = start (plan: optional, the tip starts there lifted)
    double kappa = 1.0;                 // joystick scale kappa (p = kappa r_scan p_joy)
    std::vector<LocalScanSpec> local_scans;   // in time order
    std::vector<CantileverChangeSpec> cantilever_changes;   // in time order
    std::string mode = "script";        // script: the hand follows the path; feel: a felt contact ends a segment; browser: a person on the page (realtime); env: a program, step by step (lockstep; docs/env.md)
    double feel_threshold_N = 0.02;     // feel: the stylus force against the motion that ends a segment
    HapticSpec haptic;
    HandSpec hand;
    PlanSpec plan;
};

struct OutputSpec {
    int image_px = 256;                 // square image size
    std::string video = "mp4";          // mp4 (mp4v) or avi (MJPG)
    bool png = true;                    // write frames/*.png
    bool trails = false;                // draw past object positions (the paper's fig. 18d)
    int contact_sheet_frames = 16;      // frames in contact_sheet.png (0: none)
    std::string update_mode = "local";  // local: redraw only the footprints that moved; full: every object, every frame
};

struct Scene {
    std::string file;                   // path it was read from
    std::string name;
    uint64_t seed = 1;
    double duration_s = 1.0;
    double sample_rate_hz = 20000.0;    // analog samples per second
    double block_hz = 1000.0;           // analog blocks per second (the lockstep/haptic rate)
    double frame_rate_hz = 25.0;        // display frames per simulated second
    std::string time_mode = "lockstep"; // lockstep or realtime
    // afm: the microscope's controller. The z servo moves the z piezo at
    // most this fast towards the extension its set point needs (the normal
    // force lags the set point by k_n times the distance left); 0: ideal
    // feedback, the force at the set point from the next sample on.
    double z_speed_nm_per_s = 0.0;
    InstrumentSpec instrument;          // afm's error sources (their effects listed)
    std::vector<std::string> effects;   // effects the simulator builds
    // The run's own checks this scene fails on purpose (expect:, names of
    // kVerdictChecks): the interlock scene trips the interlock. Meeting an
    // expectation passes; a check expected to fail that passes fails.
    std::vector<std::string> expect;
    // sample
    std::string substrate = "glass";   // glass, tilted_glass or polycarbonate
    // A measured substrate (sample.substrate: {gsf: FILE, material: ...}):
    // the file's absolute path and its heights (m, read and checked once by
    // load_scene: finite, at most kGsfMaxRes square, covering the field);
    // empty / null for a named substrate. `substrate` is then the material.
    std::string substrate_gsf;
    std::shared_ptr<const GsfGrid> substrate_map;
    double slope_deg = 0.0;             // tilted_glass: surface height = -y tan(slope) (rises towards -y, frame A)
    double field_nm = 5000.0;           // square field side, centred on field_center_nm
    Vec2 field_center_nm;
    ContactSpec tip_substrate;          // tip on substrate
    ContactSpec particle_substrate;     // particle on substrate
    double particle_contact_stiffness_N_per_m = 20.0;   // tip-wire penalty (sample.contact_stiffness_N_per_m; particle contacts are exact)
    double photodiode_noise_V = 0.0;    // rms; 0 with the effect listed = the lever's thermal level
    double temperature_K = 300.0;
    Vec2 drift_nm_per_min;              // linear thermal drift of the sample (thermal_drift)
    double drift_walk_nm_per_sqrt_min = 0.0;  // random-walk part of the drift (thermal_drift)
    double roughness_rms_nm = 1.0;      // rms height of the substrate's roughness (roughness)
    double roughness_corr_nm = 50.0;    // its correlation length: autocorrelation rms^2 exp(-r^2 / corr^2)
    ProbeSpec probe;
    int adc_bits = 16;                  // the card's ADC (fw_acq: 8..16)
    int word_bits = 32;                 // the card's signal chain: 32 (fw_board) or 16 (fw_board16)
    bool compensate = true;             // apex compensation (C_n, C_l); false: the piezo is taken as the apex
    FirmwareCalibration fw_cal;         // the card's calibrated constants (firmware.*)
    std::vector<ParticleSpec> particles;
    std::vector<WireSpec> wires;
    std::vector<LandmarkSpec> landmarks;
    ScatterSpec scatter;
    TargetSpec targets;
    std::vector<WireTargetSpec> wire_targets;
    WireModelSpec wire_model;
    LithoSpec litho;
    OperatorSpec op;
    OutputSpec out;

    int samples_per_block() const;      // sample_rate_hz / block_hz (validated integer)
    int64_t total_blocks() const;       // blocks in duration_s
    int total_frames() const;           // round(duration_s * frame_rate_hz)
    bool has_effect(const std::string &e) const;
    Vec2 start_nm() const;              // where the tip is at block 0: the path's first waypoint
    double load_at_nN(double t_s) const;  // the scripted load at simulated time t (operator.load_ramp_to_nN)
    // f, the wire-substrate friction per length without the down force, nN/um
    // (eq. 23-24): sample.wire.friction_nN_per_um, or mu_os F_a,os + tau_os A
    // per length when the scene gives adhesion_nN_per_um (its adhesion acting
    // with the adhesion effect alone: wire_adhesion_nN_per_um). The simulator and
    // the card's configuration both take it from here.
    double wire_friction_nN_per_um() const;
    // The wire's adhesion per length that acts, nN/um: sample.wire's
    // adhesion_nN_per_um when the scene lists the adhesion effect, else 0
    // (then the load-dependent friction has no load: f = 0, no contact
    // width), as the tip's and the particles' adhesion follow the effect.
    double wire_adhesion_nN_per_um() const;
    // The wire's contact width with the substrate, nm (A / L): Hertz's line
    // contact of a cylinder of the first wire's diameter pressed by its
    // adhesion per length (wire_adhesion_nN_per_um), b = 2 sqrt(4 P' R /
    // (pi E*)), with E* from the wire's and the substrate's moduli
    // (substrate_modulus_GPa); 0 without load-dependent friction, without
    // the adhesion effect or with contact: none.
    double wire_contact_width_nm() const;
    bool start_engaged() const;         // in contact at block 0 (not when the planner drives: it starts lifted)
};

// Two of the scene's objects closer than a given gap at the start: the one
// owner of the objects' starting geometry in the plane. The validator
// refuses an overlap (check_overlaps); ./afm check warns of objects that
// touch (host/launch/warnings.hpp). Particles (listed and scattered) are
// discs of their radius, wires stadiums of half their diameter about their
// axis, landmarks squares of their side.
struct ObjectPair {
    enum class Kind { particles, particle_wire, particle_landmark, wires };
    Kind kind = Kind::particles;
    std::size_t i = 0, j = 0;   // particle i and particle, wire or landmark j; wires: wire i and wire j (j < i)
    double apart_nm = 0;        // the centres' distance (a particle's centre to a wire's axis; two wires' axes; to a landmark's edge)
    double gap_nm = 0;          // surface to surface; negative: they overlap
    std::string key_i, key_j;   // their keys (objects.particles[2], objects.scatter (particle id 7), objects.wires[0], ...)
    int id_j = 0;               // the second one's id
};
// The pairs whose gap is below gap_nm, in the order the objects are listed.
std::vector<ObjectPair> object_pairs_within(const Scene &s, double gap_nm);

// The scripted aim's walk (operator.mode script, host/operator/hand_script.hpp):
// operator.path_nm at operator.speed_nm_per_s from its first waypoint; the
// time it reaches each waypoint, s (the first: 0). Its last is when the
// script is done.
std::vector<double> path_times_s(const Scene &s);

// The effects a scene may name.
struct EffectInfo { const char *name; const char *what; };
const std::vector<EffectInfo> &known_effects();

// Parse and validate; throws SceneError naming file, key and value. A
// scene may include files (include: FILE or [FILE, ...], relative to it)
// holding probe, firmware and sample keys: its own values win.
Scene load_scene(const std::string &path);
// The scene's YAML with its includes merged in and file paths absolute: what
// a run keeps as its scene.yaml, standing alone.
std::string resolved_scene_text(const std::string &path);

// A run's scene, identified: "fnv1a64:" and 16 hex digits of the FNV-1a hash
// of the scene's text as the run kept it (RUN/scene.yaml). An identity, not
// a seal. The launcher records it in run.json (scene_hash) and in its
// first heartbeat's detail, kScenePrefix + hash, so the log carries it;
// replay refuses a log whose hash is not its scene's.
std::string scene_hash(const std::string &text);
constexpr const char *kScenePrefix = "scene ";

}  // namespace afm
