// The simulated microscope and sample: scanner, lever, tip-sample mechanics,
// particles, drift and imaging. Double precision, own numerics (quasi-static
// relaxation), built only from the effects the scene names.
//
// Mechanics, per analog sample (quasi-static, physics.md sections 1, 4, 5
// and 5.1): the piezo moves towards its set point at the scanner's speed
// limit; then Gauss-Seidel sweeps bring the apex and the objects near it to
// Coulomb equilibrium, until the sample's residual is within the solver's
// tolerances (kSolverForceTol_nN, kSolverGapTol_nm) or the sweeps reach the
// cap (kSolverMaxSweeps; set_solver_cap): a body whose driving force exceeds
// its friction capacity moves along that force until it no longer does.
// Tip-particle and particle-particle contacts are exact constraints (a
// projected Gauss-Seidel on their forces: a contact is closed, its force
// within [0, the particle's threshold], and a particle at its threshold is
// moved to exact contact), so no stiffness enters their answer; tip-wire
// contacts are the wire's penalty (sample.contact_stiffness_N_per_m) with a
// multiplier (an augmented Lagrangian, Wire::lambda_nN) that closes them to
// kSolverGapTol_nm, and a flexible wire's step spans the sample's sweeps
// (Wire::begin_step) until it is in balance too. The apex's step uses
// the lever's stiffness plus each wire contact's secant stiffness (a sliding
// object offers a constant force: none). A uniform grid finds
// the particles near the apex, so the cost per sample does not grow with the
// number of particles far away.
//
// Frames: positions in frame A (the scanner's), nm. The sample may drift
// against the scanner (thermal_drift): particles are stored in the sample's
// own frame and shown in frame A shifted by drift().
//
// The z piezo, per sample (World::step): engaged, the z servo brings it to
// the extension that holds the normal force at the load set point; ideal
// (afm.z_speed_nm_per_s 0, the default) it gets there in the same sample;
// with a finite speed v_z it moves at most v_z / sample rate per sample,
// and the normal force is the set point plus k_n times the distance still
// to go (exact for the linear lever: k_n per nm of bending), so a pressing
// set point raises the force by at most k_n v_z per second. Disengaged
// (tip_cmd_t.engaged false: the operator's lift, or the card's interlock),
// the z piezo is retracted at once to kRetractLift_nm above the extension
// at which the tip touches with no load, and kept there (following the
// topography) while disengaged; engaged again, the servo lands it (at once
// when ideal, at v_z otherwise). Scan lines (scan_point) keep the ideal
// feedback: a scan is taken as a whole, not sample by sample.
//
// The scanner (physics.md section 17): the piezo's drive moves towards its
// set point at the scanner's speed limit (drive()); with piezo_hysteresis
// or piezo_creep the piezo is where that drive puts it through the models of
// piezo.hpp (piezo(): the truth), else at the drive. The analog block's
// piezo xy is the drive: an open-loop scanner reports what it was told, so
// the card sees the hysteresis and creep only through what it measures.
// Scans (scan_line) take each line's points where the hysteresis and the
// creep put them (the creep on the raster's own timeline, while the rest of
// the world waits: common/scan_raster.hpp) and, with scan_artefacts, show
// its line offsets, servo lag and bow. z_drift shifts the deflection
// signal's zero (set_deflection_zero_nm): the true load is the set point
// less k_n times that shift.
#pragma once

#include <Eigen/Dense>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "dilation.hpp"
#include "grid.hpp"
#include "lever.hpp"
#include "piezo.hpp"
#include "scan_artefacts.hpp"
#include "scene.hpp"
#include "tip_geometry.hpp"
#include "wire.hpp"

namespace afm::sim {

// A lithography trench (physics.md section 9): points along the tip path, in
// the sample's frame, each with the depth cut there and the width of the V
// the cone leaves (2 depth tan gamma).
struct Trench {
    int id = 0;
    std::vector<Eigen::Vector2d> p;   // nm, sample frame
    std::vector<double> depth_nm, width_nm;
};

struct Particle {
    int id;
    Eigen::Vector2d c;     // centre, sample frame, nm
    double r;              // radius, nm
    double threshold_nN;   // static friction capacity against a lateral push, F_th(0) (without the cone's down force)
    double reach_nm = 0;   // apex to centre in the plane at contact (World::init_reach)
    bool in_contact = false;
    double push_nN = 0;    // the apex's contact force on it, nN (the solver's multiplier; kept as the next sample's start)
    double chain_nN = 0;   // the force it passes on to the particles it pushes, along its push, nN (particle_contacts)
};

// The contact solver's tolerances and cap (physics.md 5.1). A sample is
// converged when the apex's force balance is within kSolverForceTol_nN (the
// force the substrate's friction cannot take) and every contact within
// kSolverGapTol_nm (no penetration, no gap under load); its sweeps stop there
// or at the cap, and a sample left at the cap counts as unconverged.
constexpr double kSolverForceTol_nN = 0.002;
constexpr double kSolverGapTol_nm = 0.01;
constexpr int kSolverMaxSweeps = 200;

struct Sample {
    double sn_v, sl_v;            // photodiode outputs, V (saturated at +-10 V)
    Eigen::Vector3d piezo_nm;     // frame A
};

// One point of a contact-mode scan line (World::scan_point).
struct ScanPoint {
    double height_nm;             // the height image: z extension + set-point deflection (saturates with z)
    double sn_v, sl_v;            // photodiode outputs, V (saturated at +-10 V)
};

// The scanner's range (physics.md section 12): xy within kScannerRangeXY_nm / 2
// of its centre, the origin of frame A (scene.hpp: the validator keeps the
// field inside it); the z extension within kScannerRangeZ_nm, engaged at mid
// range on the substrate's reference plane (height 0), so z in [-2.5, +2.5] um.
// Beyond it the set point is clamped (World::command, World::step).

// Substrate roughness (effect roughness): a sum of kWaves cosines with random
// phases whose wave vectors sample the Gaussian spectrum of the
// autocorrelation rms^2 exp(-r^2 / corr^2) (per component k ~ N(0, 2 / corr^2)):
// radii stratified (one per quantile bin of the Rayleigh law, jittered),
// angles on a golden-angle sequence with a random start, so one realization's
// rms and autocorrelation sit close to the ensemble's. Deterministic from the
// scene seed; drawn from its own generator (the sample effects' stream is
// untouched).
class RoughSurface {
public:
    static constexpr int kWaves = 256;
    RoughSurface(double rms_nm, double corr_nm, uint64_t seed);
    double height(const Eigen::Vector2d &q) const;          // nm, sample frame
    Eigen::Vector2d gradient(const Eigen::Vector2d &q) const;
    // Adds height() at the n points (x + i h, y), i < n, to out[i] (a row of
    // the imaging's lattice: each wave's phase stepped, not recomputed).
    void add_row(double x, double y, int n, double h, double *out) const;
    double amplitude_bound_nm() const { return amp_ * kWaves; }   // |height| never exceeds it

private:
    std::vector<Eigen::Vector2d> k_;   // rad/nm
    std::vector<double> phase_;        // rad
    double amp_ = 0;                   // rms sqrt(2 / kWaves), nm
};

// A measured substrate (sample.substrate: {gsf: FILE}): the map's heights
// (m -> nm) interpolated bilinearly between its pixel centres (the GSF's
// grid: common/gsf.hpp), in the sample frame; beyond the outermost pixel
// centres (the scene reader makes the map cover the field, not the whole
// scanner range) the nearest edge's heights continue, flat across it.
class MeasuredSurface {
public:
    explicit MeasuredSurface(const GsfGrid &g);
    double height(const Eigen::Vector2d &q) const;          // nm, sample frame
    Eigen::Vector2d gradient(const Eigen::Vector2d &q) const;   // of height(), 0 across an edge
    double span_nm() const;                                  // highest less lowest pixel, nm

private:
    // The cell of q: column i, row j (row 0 at the top, the largest y), the
    // fractions t (along x) and u (down the rows) in it, and whether q lies
    // beyond the map in x / in y.
    void cell(const Eigen::Vector2d &q, int *i, int *j, double *t, double *u, bool *out_x, bool *out_y) const;
    int nx_ = 0, ny_ = 0;
    double x0_nm_ = 0, ytop_nm_ = 0;   // centre of the top-left pixel, nm
    double dx_nm_ = 1, dy_nm_ = 1;     // pixel pitch, nm
    std::vector<double> h_nm_;         // ny_ rows of nx_, row 0 at the top, nm
};

// Wall time spent in one named effect (or core stage) of the simulator.
struct EffectClock {
    std::string name;
    double seconds = 0;
};

// The retract: a disengaged tip's z piezo stands this far above the
// extension at which the tip touches the surface with no load (the card's
// interlock documents it as its retract, firmware/include/fw_guard.h).
constexpr double kRetractLift_nm = 100.0;

class World;

// An effect that acts on every sample. Built only when the scene names it;
// an effect not named is not in the list and costs nothing per sample.
class SampleEffect {
public:
    explicit SampleEffect(std::string name) : name_(std::move(name)) {}
    virtual ~SampleEffect() = default;
    // Called after the mechanics and the lever; may change the photodiode volts.
    virtual void apply(World &w, double &sn_v, double &sl_v) = 0;
    const std::string &name() const { return name_; }
    double seconds = 0;

private:
    std::string name_;
};

class World {
public:
    explicit World(const Scene &s);

    // Set point from the firmware (AFM_CMD).
    void command(const Eigen::Vector2d &piezo_nm, double load_nN, bool engaged);
    Sample step();                                 // one analog sample

    const Eigen::Vector2d &apex() const { return apex_; }       // frame A
    const Eigen::Vector2d &piezo() const { return piezo_; }     // frame A, where the piezo is
    const Eigen::Vector2d &drive() const { return drive_; }     // frame A, where it was told to be (speed-limited)
    double piezo_z() const { return piezo_z_; }
    Eigen::Vector3d tip_force() const;             // sample on tip, frame A, nN
    const std::vector<Particle> &particles() const { return particles_; }
    Eigen::Vector2d particle_position(std::size_t i) const { return particles_[i].c + drift_; }  // frame A
    const std::vector<std::unique_ptr<Wire>> &wires() const { return wires_; }
    Eigen::Vector2d to_frame_A(const Eigen::Vector2d &sample_nm) const { return sample_nm + drift_; }
    const std::vector<Trench> &trenches() const { return trenches_; }
    // Lithography (the effect calls it once per sample): cuts at the apex when
    // the load exceeds the threshold.
    void engrave();
    const Eigen::Vector2d &drift() const { return drift_; }
    void add_drift(const Eigen::Vector2d &d) { drift_ += d; }
    // z_drift: the deflection signal reads d_nm more than the lever bends;
    // the servo holding the signal leaves the true load k_n d_nm below the set point.
    void set_deflection_zero_nm(double d_nm)
    {
        zero_load_nN_ = lever_.spring * d_nm;
        load_nN_ = load_set_nN_ - zero_load_nN_;
    }
    double dt() const { return dt_; }
    std::mt19937_64 &rng() { return rng_; }
    const Lever &lever() const { return lever_; }
    // Samples in which the piezo's set point lay beyond the scanner's range
    // (xy or z) and was clamped to it.
    int64_t piezo_clamped_samples() const { return clamped_samples_; }
    // Scan points whose position or z extension was clamped likewise.
    int64_t scan_points_clamped() const { return scan_clamped_; }
    // Samples in which the tip rode over a wire it pushed (down_force; the tip's
    // vertical balance with the 3-D contact's normal, lift_off_push).
    long ridden_samples() const { return ridden_samples_; }

    // The flexible wires' solver over the run (FlexibleWire's counters,
    // summed; sim_report.json's wire_solver): pushes solved, the most Newton
    // iterations one took against the cap, pushes left unconverged at the
    // cap and Newton steps on a singular system. flexible == 0: no flexible
    // wire in the scene, nothing counted.
    struct WireSolver {
        int flexible = 0;
        long solved = 0, unconverged = 0, regularised = 0;
        int worst_iterations = 0, max_iterations = 0;
    };
    WireSolver wire_solver() const;

    // Imaged height at (x, y) in frame A, nm: the surface, dilated by the tip
    // when the scene lists tip_convolution.
    double image_height(double x, double y) const;
    // A contact-mode scan line in +x (frame A) at the scene's load, at (x, y):
    // height, and the photodiode outputs of the tip sliding there, from the
    // same contact physics as the mechanics (sliding_friction) with the
    // imaged surface's local normal; ideal z feedback holds F_z at the set
    // point, so S_n is the set point plus the moment of F_x (eq. 1c).
    ScanPoint scan_point(double x, double y) const;
    // A scan line in +x at the commanded x_i = x0 + i dx (i < n) and y, one
    // line of a raster whose first line is at y_first and whose lines are
    // dy apart (0: the line is the raster's first in time), into out[0..n):
    // each point's scan_point where the scanner puts it (PiezoXY::raster_line:
    // the hysteresis from its present state along the raster, the creep of
    // every step before the point on the raster's timeline,
    // common/scan_raster.hpp), then the scan artefacts (heights; the servo's
    // tracking error in S_n). Without those effects, scan_point at each x_i.
    void scan_line(double x0, double dx, int n, double y, double y_first, ScanPoint *out, double dy = 0) const;

    // Per effect, seconds of wall time. The per-sample stages (mechanics,
    // wire pushes, the per-sample effects) are timed in 1 sample of
    // kClockEvery, picked at random (its own generator, not the physics'),
    // and scaled by samples / samples timed: reading the clock around every
    // stage of every sample cost more than some stages (4 reads a sample,
    // on the lockstep's path). Imaging is
    // timed whole. Before a sample is timed, the per-sample stages read 0.
    std::vector<EffectClock> clocks() const;
    static constexpr uint32_t kClockEvery = 16;
    int64_t samples_stepped() const { return samples_; }
    int64_t samples_timed() const { return timed_samples_; }
    std::vector<std::string> models_built() const; // every model and effect constructed

    // The contact solver over the run (sim_report.json's solver): samples
    // solved (the tip touching), sweeps in all and the most one sample took,
    // the worst residual a sample ended with (force, nN; contact gap, nm),
    // and the samples left unconverged at the cap.
    struct SolverStats {
        long samples = 0, sweeps = 0, unconverged = 0;
        int max_sweeps = 0, cap = kSolverMaxSweeps;
        double worst_force_nN = 0, worst_gap_nm = 0;
    };
    const SolverStats &solver() const { return solver_; }
    // The cap on sweeps per sample (default kSolverMaxSweeps; at least 1).
    void set_solver_cap(int n) { solver_.cap = n < 1 ? 1 : n; }

private:
    using Clock = std::chrono::steady_clock;
    void relax();
    // relax()'s parts, one Gauss-Seidel sweep each: the force on the apex
    // (and which wire contacts press it, wire_links_); the force the
    // substrate cannot take (its excess, frame A); the apex's step in the
    // stiffness it meets (step_stiffness), stopped at the surface of a wire
    // contact it would enter (stop_at_wires); the contacts.
    Eigen::Vector2d apex_pull(const Eigen::Vector2d &rest);
    Eigen::Vector2d apex_excess(const Eigen::Vector2d &g, double fz, const Eigen::Vector3d &normal) const;
    void slide_apex(const Eigen::Vector2d &excess);
    double step_stiffness(const Eigen::Vector2d &m) const;
    double stop_at_wires(const Eigen::Vector2d &m, double t);
    void push_particles(bool chains);
    void push_neighbours(std::size_t q);
    bool wires_settled() const;   // every wire's step in balance (Wire::settled)
    void record_solve(int sweeps, double force_nN, double gap_nm, bool converged);
    void push_wires(const Eigen::Vector2d &as2);
    void relax_rigid();
    double height_true(double x, double y) const;
    double height_convolved(double x, double y) const;
    double base_height(const Eigen::Vector2d &q) const { return (this->*base_)(q); }   // sample frame
    double base_plane(const Eigen::Vector2d &q) const { return -q.y() * tan_slope_; }
    double base_rough(const Eigen::Vector2d &q) const { return -q.y() * tan_slope_ + rough_->height(q); }
    // a measured substrate (never tilted), roughness added when listed
    double base_measured(const Eigen::Vector2d &q) const { return measured_->height(q) + (rough_ ? rough_->height(q) : 0.0); }
    // Unit normal of the substrate (without objects) at q, sample frame.
    Eigen::Vector3d normal_plane(const Eigen::Vector2d &) const { return normal_; }
    Eigen::Vector3d normal_rough(const Eigen::Vector2d &q) const;
    Eigen::Vector3d normal_measured(const Eigen::Vector2d &q) const;
    double groove_depth(const Eigen::Vector2d &q) const;    // lithography, sample frame
    // Rods sink into trenches (physics.md section 9): a rigid rod whose axis
    // lies, over at least half its length, in a V-groove at least as wide as
    // it settles onto the groove's path (it slides down the walls: each of
    // 17 points along it has its target across the groove on the path; the
    // rod turns to the targets' line, their regression on the place along
    // the rod, and its centre moves to its foot on that line, never along
    // the groove) and rests on both walls, its axis at z = -D + R / sin gamma
    // (negative: below the substrate; D: the groove's mean depth under it; the walls meet it
    // below the surface, as D tan gamma >= R cos gamma holds in any groove
    // as wide as the rod). After each sample's mechanics, with
    // trenches only, with no allocation. rod_axis_z_: each wire's axis height above the
    // substrate plane (R on the flat), for the images.
    void settle_rods();
    bool trench_seat(const Eigen::Vector2d &q, double d_nm, Eigen::Vector2d *to_centre, double *depth) const;
    // The trench pieces near q, nearest point, depth and direction, until accept() takes one (trench_seat, trench_hold).
    template <class F> bool first_trench_piece(const Eigen::Vector2d &q, F accept) const;
    std::vector<double> rod_axis_z_;
public:
    double wire_axis_height_nm(std::size_t i) const;   // wire i's axis above the substrate plane (R unless sunk), nm
    std::vector<double> wire_axis_heights_nm() const;  // every wire's, in the scene's order
private:
    bool trench_hold(const Eigen::Vector2d &q, double d_nm, Eigen::Vector2d &along, double &hold) const;
    void press_cone();                                        // down_force: each wire's tan psi and the pushed particle's factor for this sample
    void build_wires(const Scene &s);                         // the scene's wires, as its effects model them (constructor)
    double ride_push_nN(std::size_t i) const;                 // the most the tip can push wire i before it lifts (down_force)
    // The contacts' reach (constructor): each particle's reach_nm, the
    // distance in the plane from the apex to its centre at contact, and the
    // tip radius wire_rt_[i] each wire's planar contact takes: the apex's
    // circle, R + r (world_contact.cpp says why not yet the 3-D reach).
    void init_reach();
    std::vector<double> wire_rt_;
    double max_reach_nm_ = 0;      // the largest particle reach, nm
    // The 3-D contact of the tip at the apex's place with wire i's segment
    // nearest it, as lift_off_push sees it (tip_geometry.hpp).
    LiftInput wire_lift_input(std::size_t i, double H_friction_nN) const;
    void count_ridden();                                      // one of ridden_samples_ if a wire was ridden this sample
    // Horizontal force of the substrate on the tip, frame A, when it slides
    // along the horizontal direction m on a surface of unit normal n under the
    // vertical force fz; none when the slope is too steep to climb (the tip
    // jams: no finite force slides it up).
    std::optional<Eigen::Vector2d> sliding_friction(const Eigen::Vector2d &m, const Eigen::Vector3d &n, double fz) const;
    // Photodiode outputs of a jammed tip: the force against the motion m is
    // unbounded, so each output sits at its limit on that force's side.
    void saturate_against(const Eigen::Vector2d &m, double &sn, double &sl) const;
    // Ideal z feedback over a surface at height surface_nm with F_x (frame
    // C) on the tip: the extension holding the set point fz, clamped to the
    // range; the normal force then acting (fz plus k_n times the shortfall)
    // and whether the tip still touches (that force above -F_adh).
    // z_need_nm: the extension the set point needs, before the clamp.
    struct ZHold { double z_nm, fz_nN; bool clamped, touching; double z_need_nm; };
    ZHold hold_z(double surface_nm, double fx_C, double fz) const;
    // The finite z servo (z_speed_nm_per_s_ > 0): from piezo_z_ at most one
    // sample's travel towards the ideal hold's z; the normal force the set
    // point fz plus k_n times the extension still missing (z_need - z), the
    // tip touching while that is above -F_adh.
    ZHold slew_z(const ZHold &ideal, double fz) const;
    // A hold whose z falls short of z_need: the normal force the set point
    // fz plus k_n times the shortfall; 0 and not touching once it pulls the
    // tip off (beyond the adhesion).
    ZHold short_of(ZHold h, double fz) const;
    // Normal force the mechanics acts with this sample: the set point plus
    // the z shortfall of the last sample; 0 when lifted off or not engaged.
    bool touching() const { return engaged_ && !lifted_; }
    double contact_load() const { return touching() ? load_nN_ + z_excess_nN_ : 0.0; }
    void near(const Eigen::Vector2d &p, double radius, std::vector<int> &out) const;

    const Scene scene_;            // a copy: a World outlives the Scene it was built from
    Lever lever_;
    Eigen::Matrix2d K_;            // lever lateral stiffness at the apex, frame A, nN/nm
    double k_lever_max_;           // its largest eigenvalue
    double k_contact_;             // tip-wire penalty stiffness, nN/nm
    double dt_;                    // sample period, s
    double scanner_speed_nm_per_s_ = 20000.0;
    double z_speed_nm_per_s_ = 0.0;     // afm.z_speed_nm_per_s: 0 is the ideal z servo
    bool z_started_ = false;            // piezo_z_ holds a sample's extension (the first sample settles at once)
    SolverStats solver_;
    // Each wire's contact as the apex's step sees it: a secant stiffness
    // along the contact's normal, from the force after the wire's push at
    // two apex positions (k_nN_per_nm, clamped to [0, k_contact_]; k_contact_
    // until measured), and the last such point of this sample (s_nm: the
    // apex along the normal, f_nN: the force; fresh: taken in this sample).
    // pressing: the contact pushed the apex at this sweep (or the last step
    // stopped at its surface: touched), along n (from the wire to the apex).
    // An advance into the wire meets the secant; a retreat k_contact_ (the
    // contact unloads; the wire does not follow the apex back).
    struct WireLink {
        double k_nN_per_nm = -1, s_nm = 0, f_nN = 0;
        bool fresh = false;
        bool pressing = false, touched = false;
        Eigen::Vector2d n = Eigen::Vector2d::Zero();
        double kt_nN_per_nm = 0;   // across n: the contact's stiffness as the apex slides along the wire held (its normal turns)
    };
    std::vector<WireLink> wire_links_;
    void measure_wire_links();
    void open_wire_contacts();    // at a sample's start: a contact apart loses its multiplier
    void close_wire_contacts();   // each wire's multiplier: its contact force after the push
    bool particle_chains_ = false; // particle_contacts: pushed particles push their neighbours
    double wire_gap_nm_ = 0;       // the worst wire contact's gap under load (penetration, or apart with force), nm
    double sweep_gap_nm_ = 0;      // the worst contact gap apex_pull saw (penetration, or a gap under load), nm
    double max_radius_ = 0;        // largest particle radius, nm

    Eigen::Vector2d piezo_, target_, apex_;
    Eigen::Vector2d drive_;                   // the speed-limited command, frame A
    std::unique_ptr<PiezoXY> piezo_model_;    // piezo_hysteresis, piezo_creep; null without them
    std::unique_ptr<ScanArtefacts> artefacts_;   // scan_artefacts; null without it
    double load_set_nN_ = 0;                  // the card's load set point (load_nN_: the true one)
    double zero_load_nN_ = 0;                 // z_drift: k_n times the deflection signal's zero shift
    Eigen::Vector2d drift_{0.0, 0.0};   // sample against scanner, nm
    double piezo_z_ = 0;
    double load_nN_ = 0;
    bool engaged_ = false;
    bool target_clamped_ = false;       // the xy set point lay beyond the range
    double z_excess_nN_ = 0;            // k_n times the z shortfall at the last sample
    bool lifted_ = false;               // the z range (or a finite servo's z, on its way down) keeps the tip off the surface
    bool jammed_ = false;               // rigid lever against a slope it cannot climb
    int64_t clamped_samples_ = 0;
    mutable int64_t scan_clamped_ = 0;
    double tip_adhesion_nN_ = 0;
    double tip_mu_ = 0;
    long ridden_samples_ = 0;      // samples the tip rode over a wire (down_force)
    bool down_force_ = false;      // the cone presses what it pushes (effect down_force)
    double gamma_rad_ = 0;         // the cone's half angle
    double cos_gamma_ = 1, sin_gamma_ = 0, tan_gamma_ = 0;   // of gamma_rad_, once
    double particle_mu_ = 0;       // mu_ps
    double cone_factor_ = 1;       // down_force: 1 / (1 - mu_ps tan psi) on the threshold of the particle the tip pushes
    Eigen::Vector2d last_motion_{1.0, 0.0};    // unit, frame A: direction of the last apex move
    Eigen::Vector2d lateral_force_{0.0, 0.0};  // sample on tip, frame A, nN
    std::vector<Particle> particles_;
    std::vector<LandmarkSpec> landmarks_;   // fixed pillars, sample frame (section 10)
    // The objects' height above the substrate at q (sample frame): the
    // particles', the wires' (at their axis height), the landmarks'; -inf
    // where there is none.
    double object_profile(const Eigen::Vector2d &q) const;
    // The imaging (world_imaging.cpp, dilation.hpp): the tip's image of the
    // present state over a lattice of pitch h through (x0, y0), frame A,
    // kept while the state it shows (imaging_state) and the lattice stay;
    // the lattice's pitch for a scan of pitch dx; the map's rows.
    std::shared_ptr<const DilatedField> dilated(double x0, double y0, double h) const;
    std::shared_ptr<const DilatedField> dilated_default() const;   // the display's pixels (image_height, scan_point)
    double lattice_pitch(double dx) const;
    void imaging_state(std::vector<double> &out) const;
    void fill_map(double x, double y, int n, double h, double *base, double *groove, double *object) const;
    ScanPoint scan_point_on(const DilatedField *f, double x, double y) const;
    mutable std::shared_ptr<const DilatedField> dilated_;
    mutable std::vector<double> dilated_state_, state_now_;
    std::vector<std::unique_ptr<Wire>> wires_;   // empty unless the scene has wires
    double tan_slope_ = 0;                       // tilted_glass: height = -y tan(slope)
    Eigen::Vector3d normal_{0.0, 0.0, 1.0};      // substrate unit normal
    std::vector<Trench> trenches_;
    Grid trench_grid_{1.0};                      // indexes trench_points_
    std::vector<std::pair<int, int>> trench_points_;   // (trench, point) of every cut point
    double trench_reach_nm_ = 0;                 // largest half width cut so far
    double trench_step_nm_ = 0;                  // longest piece of path between trench points
    bool cutting_ = false;
    Grid grid_;
    mutable std::vector<int> scratch_, scratch2_, scratch3_;
    mutable std::vector<double> scratch_line_;   // scan_line's heights and servo errors
    mutable std::vector<double> raster_x_;       // scan_line's points where the scanner puts them: x, then y

    // Chosen once at construction (no per-sample flag tests).
    void (World::*mechanics_)();
    double (World::*imaging_)(double, double) const;
    double (World::*base_)(const Eigen::Vector2d &) const;
    Eigen::Vector3d (World::*normal_at_)(const Eigen::Vector2d &) const;
    std::unique_ptr<RoughSurface> rough_;   // only when the scene lists roughness
    std::unique_ptr<MeasuredSurface> measured_;   // only on a measured substrate
    std::vector<std::unique_ptr<SampleEffect>> per_sample_;
    std::mt19937_64 rng_;
    // The clocks (clocks()): sums over the timed samples only.
    double t_mech_ = 0;
    double t_wires_ = 0;           // inside t_mech_: wire pushes
    bool timed_ = false;           // this sample is timed
    // A timed sample's stage: its start, then its wall time added to *sum
    // (an untimed sample's: no clock read, nothing added).
    Clock::time_point clock_start() const;
    void clock_add(double *sum, Clock::time_point t0) const;
    uint32_t clock_pick_ = 0x9E3779B9u;   // xorshift32 state picking the timed samples
    int64_t samples_ = 0, timed_samples_ = 0;
    mutable double t_scan_ = 0;
};

// The registry: builds the per-sample effects a scene names.
std::vector<std::unique_ptr<SampleEffect>> build_sample_effects(const Scene &s, const Lever &lever);

}  // namespace afm::sim
