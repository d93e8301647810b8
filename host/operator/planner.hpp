// The automatic planner (operator.plan): pushes particles onto target sites
// and rods to target poses, closed loop on the firmware's models.
//
// 1. Assignment: a pinned site (objects.targets[j].particle) gets its
//    particle; the rest, particles to sites at minimum total travel (dlib's
//    max_cost_assignment, the Hungarian method; costs in 0.1 nm). More
//    sites than particles is an error; spare particles stay where they are,
//    but one that lies on a site another particle is coming to (closer
//    than a diameter plus the clearance) is pushed out of the way first.
// 2. Order and paths: the sites in assembly order (assembly_order: the
//    pattern taken apart from outside in, reversed, so each site can still
//    be reached when its turn comes); at each step the first particle in
//    that order with a free push (plan_push: straight or two legs, clear of
//    every other particle, never along the lever's axis; a particle already
//    closer than the clearance to another may move, but not closer). A particle with
//    no free push waits for a later round; when none of the rest has one,
//    they are reported unplaced ("no free path").
// 3. Each push, closed loop, in strokes: travel lifted to the particle; a
//    local scan (before its first stroke: drift, when a second particle
//    shows the same offset, else a place fix); land approach_nm behind its
//    surface; steer: every block the tip aims push_depth_nm into the
//    particle's modelled surface (FW_STATE's objects) on the line from the stroke's
//    end through its centre, at speed_nm_per_s; a stroke ends when the
//    model is within 2 nm of its end (onto the site: slowing over the last
//    40 nm, within 0.5 nm); back off, lift. After every stroke a local scan
//    puts the model where the particle is (a place fix); the next stroke
//    grows while the model stays within 5 nm of the scan and halves when it
//    strays past 15. Onto the site, a particle more than half the
//    tolerance off is pushed again (on the last of max_pushes attempts the
//    tolerance itself is taken), then reported. Near another particle a
//    stroke is at most 180 nm (stroke_length): a pushed sphere that turns
//    off the line and slips off the tip must not reach its neighbour. A
//    lifted move never runs along the lever's axis (lifted_route). Contact lost (the line of
//    centres more than 60 deg off the push, the particle out of reach, the
//    tip at its aim while the model stays still, or the model moving in
//    fewer than half of the last 20 ms of blocks: the particle slipped off
//    and the card feels a contact only now and then) ends the stroke.
// 4. Rods (objects.wire_targets): a zigzag of end pushes perpendicular to
//    the axis, as the paper advises (never the middle: the bifurcation).
//    An end push at l = L/10 turns the rod about its static point s(l)
//    (the firmware's, with the trenches the card recorded holding it:
//    fw_wire_hold, fw_wire_static_point_held): the ends move dn (0 - s) /
//    (l - s) and dn (L - s) / (l - s). From the two ends' normal errors e_A,
//    e_B the two end pushes that would remove both are solved, and the
//    larger is made, at most wire_step_nm (an end a trench holds turns the
//    rod about itself: the solve then leans on the other end). A rod moves only along its normal: while its
//    centre is more than 3 tolerances from the target it is turned until
//    its normal points there (e_A = -e_B) and carried along it (e_A =
//    e_B); then its ends are pushed to the target's. Done when both ends
//    are within wire_tolerance_nm (by the model; the fresh scan at the end
//    checks it), or when a trench holds the rod's model along its whole
//    length (it goes no deeper: the target is then the trench, and
//    wire_tolerance_nm should allow for (width - d) / 2); a rod whose model
//    three pushes in a row leave where it was is reported stuck.
//
// 0. Cuts (operator.plan.cuts), before anything is pushed: the tip travels
//    lifted to a line's start, lands, is pressed to the cut's load, runs
//    along the line at speed_nm_per_s and lifts; the card records the
//    trench (fw_litho), and its wire models feel it (fw_wire_hold).
//
// Time: a local scan is taken at once by the simulator; the planner then
// holds the tip lifted for scan_s (the time a real one keeps the tip busy).
// Positions: frame A, nm. Sites are given in the sample's coordinates;
// the planner aims at site + the firmware's drift estimate. A pre-push
// scan that finds a particle off its model by more than the scan's
// scatter (4 nm) scans the nearest other particle too: off by the same, it
// is drift (a drift fix: every model moves); if not, the particles were
// disturbed (a push the models did not see), and each model alone is put
// right (place fixes). Under the card's Kalman filter
// (firmware.drift_filter: kalman) a pre-push scan within the scatter is a
// drift fix too (the filter takes its share of it, so every pre-push scan
// feeds it), and a drift fix the filter took in part is followed by a place
// fix (the particle's model where the scan shows it). Another particle's
// model counts as disturbed by a push when it moved by more than the card's
// drift estimate moved meanwhile (the Kalman filter moves every model each
// block).
#pragma once

#include <opencv2/core.hpp>

#include <stdexcept>
#include <string>
#include <vector>

#include "afm/objects_t.hpp"
#include "display.hpp"
extern "C" {
#include "fw_wire.h"
}
#include "scene.hpp"

namespace afm {

class PlanError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Thrown by a PlanInstrument when the run ends while the planner works.
struct PlanStopped {};

// Particles to sites at minimum total travel: result[j] is the particle
// index for site j. Throws PlanError when there are more sites than
// particles (or none of either).
std::vector<int> assign_sites(const std::vector<Vec2> &particles, const std::vector<Vec2> &sites);
// The same with pinned sites (objects.targets[j].particle): pinned[j] is
// the particle index that must go to site j, or -1; the other sites get
// the other particles at minimum total travel. pinned may be empty (none).
// Throws PlanError for a pinned index out of range or given twice.
std::vector<int> assign_sites(const std::vector<Vec2> &particles, const std::vector<Vec2> &sites, const std::vector<int> &pinned);

// A disc in the plane: something a push must keep clear of.
struct Disc { Vec2 c; double r = 0; int id = 0; };

// What a push sweeps: the particle (radius r), the tip (tip_r) behind it
// along each leg, landing approach_nm further back at each leg's start;
// neither may come within clearance_nm of another particle's surface. No
// leg may run within min_lever_angle_deg of the lever's axis (lever_axis,
// frame A): pushed along the lever the firmware cannot tell the push's
// force from friction (F_x unobservable, fw_force.h), so its model would
// lose the particle.
struct PushGeometry {
    double r = 50, tip_r = 10, approach_nm = 60, clearance_nm = 40;
    Vec2 lever_axis{1, 0};
    double min_lever_angle_deg = 0;
};

// A push from `from` to `to`: the particle's centre runs through `legs`
// (first = from, last = to); empty if none is free. Straight if it can be;
// else two legs through a via point: the site approached from one of 16
// directions, the line bent aside around its middle, or a zigzag of the two
// directions at min_lever_angle_deg either side of the lever's axis; the
// shortest free one.
struct PushPath {
    std::vector<Vec2> legs;
    double length_nm = 0;
    bool ok() const { return legs.size() >= 2; }
};
PushPath plan_push(Vec2 from, Vec2 to, const PushGeometry &g, const std::vector<Disc> &obstacles);

// How far one stroke pushes from `from` along a leg ending at leg_end
// (sample coordinates, nm): the whole leg when it is at most 1.5 limit,
// else limit. limit is stroke_nm, or near_nm (if shorter) when a particle
// pushed that far could come within clearance_nm of another: a sphere
// pushed by a sphere turns off the line of centres (the real one and the
// card's model alike, from starts a scan's error apart), up to r + tip_r
// aside before it slips off the tip; a short stroke leaves it no time to.
double stroke_length(Vec2 from, Vec2 leg_end, double stroke_nm, double near_nm, const PushGeometry &g,
                     const std::vector<Disc> &obstacles);

// The lifted tip's way from `from` to `to` (frame A, nm): the points it
// goes through after `from`, the last `to`. Straight, unless the line runs
// within min_lever_angle_deg of the lever's axis: then through one corner
// that turns both legs 35 deg or more off the axis, on the side nearer
// `centre`. (The card flags a blind push whenever its direction of motion
// lies within 14.5 deg of the axis with the apex over an object it
// models, lifted or not: fw_card.c.)
std::vector<Vec2> lifted_route(Vec2 from, Vec2 to, const PushGeometry &g, Vec2 centre);

// Sites in an order that keeps each reachable: assembly as disassembly
// reversed. From the whole pattern, the site that can be reached last
// (approached straight from a particle's length away along a direction
// the geometry allows, clear of every other site's particle) is taken
// away, again and again; sites never reachable come first, innermost
// first. Indices into `sites`.
std::vector<int> assembly_order(const std::vector<Vec2> &sites, const PushGeometry &g);

// What the planner sees of the instrument, the card and the microscope (the operator implements it).
struct PlanPose {
    Vec2 tip_nm;
    bool engaged = false;
    double load_nN = 0;         // while engaged; 0: operator.load_nN (a cut presses harder)
};
class PlanInstrument {
public:
    virtual ~PlanInstrument() = default;
    // Holds `pose` (the apex target) for the next block; returns the
    // firmware's model after that block. May throw PlanStopped.
    virtual const objects_t &block(const PlanPose &pose) = 0;
    // A local scan of the square `f` now: heights, nm, row 0 at the top.
    virtual cv::Mat scan(const Field &f) = 0;
    // Tells the firmware where a scan found a particle (place: its model
    // alone; else drift); returns the model after it and what the card
    // said (empty if it applied it).
    virtual const objects_t &fix(int particle_id, Vec2 at_nm, bool place, std::string *note) = 0;
    virtual double time_s() const = 0;   // simulated time of the last block
};

struct PlanItem {               // one particle's or rod's account
    std::string kind;           // "particle" or "wire"
    int id = 0;
    Vec2 target_nm;             // the site (sample coordinates)
    double target_angle_deg = 0;   // rods
    int pushes = 0;             // push attempts (a rod: end pushes)
    int scans = 0;
    bool placed = false;        // within tolerance at its last check (a scan)
    double error_nm = -1;       // at its last check (-1: never checked)
    std::string why;            // when not placed
    std::string note;           // how the pushes ended, when not by the target (a rod: held by a trench)
};

struct PlanReport {
    std::vector<PlanItem> items;
    int pushes = 0, repushes = 0, local_scans = 0, fixes = 0, fixes_refused = 0, cleared = 0;
    int disturbed = 0;          // other particles' models that moved during a push (each checked by a scan)
    int cuts = 0;               // lines cut (operator.plan.cuts)
    double cuts_done_s = -1;    // simulated time the last cut ended (-1: none)
    int replaced = 0;           // placed particles knocked off and pushed back
    double finished_s = -1;     // simulated time the plan finished (-1: the run ended first)
    double wall_s = 0;
};

// One site and the particle run() pushes to it (PlanJob.site: an index in sites()).
struct PlanJob { int site = 0; int particle = 0; };

class Planner {
public:
    // Throws PlanError / PatternError when the scene's targets cannot be served.
    explicit Planner(const Scene &s);
    // The whole plan, block by block through `instrument`; returns when done.
    // Throws PlanStopped if the instrument stops it.
    void run(PlanInstrument &instrument);
    // One particle pushed to one place, as run() pushes each to its site
    // (place_particle: the scan before, the strokes, the scan after each,
    // the fixes; pushed again up to max_pushes while more than half the
    // tolerance off): the tip starts lifted at tip_nm (frame A), the target
    // is in frame A as the display shows it (the planner aims at it; its
    // site is the target less the firmware's drift). Returns the
    // particle's account, also appended to report().items. The scene need
    // not plan (operator.mode browser asks for these one at a time: PUSH,
    // hand_input.hpp); operator.plan's settings apply, their defaults if
    // it is not given. Throws PlanStopped if the instrument stops it.
    PlanItem push_particle(PlanInstrument &instrument, int id, Vec2 target_nm, Vec2 tip_nm);
    // The particles' jobs as run() takes them up, from the card's objects
    // `model` (frame A, its drift_nm taken off): each site's particle
    // (assign_sites, pinned sites kept) in assembly order (assembly_order).
    // run() pushes the first of them with a free push, again and again;
    // operator --plan-jobs prints them for a policy outside (docs/env.md).
    std::vector<PlanJob> jobs(const objects_t &model) const;
    const PlanReport &report() const { return rep_; }
    const std::vector<Vec2> &sites() const { return sites_; }

private:
    struct Job;
    const Scene &s_;
    std::vector<Vec2> sites_;
    PlanReport rep_;
    PlanInstrument *instrument_ = nullptr;
    const objects_t *model_ = nullptr;
    Vec2 tip_;                  // the apex target last given
    bool engaged_ = false;
    double load_nN_ = 0;        // the load the tip is held at (0: operator.load_nN)
    double stroke_nm_;          // the next stroke's length (planner_internal.hpp: kStroke*)
    fw_wire_tip_t wire_tip_{};  // the card's (CardSetup): what a rod's model is pushed with

    Vec2 drift() const;
    const particle_t *particle(int id) const;
    std::vector<Disc> obstacles(int except_id) const;   // every other particle, sample coordinates
    PushGeometry geometry(double r) const;
    void hold(int blocks);
    void travel(Vec2 to, bool engaged, double speed);
    void cut(const CutSpec &c);
    void wait_s(double s);
    bool scan_at(int id, Vec2 around, Vec2 *found);
    bool send_fix(int id, Vec2 at, bool place);   // false: the card refused it
    bool scan_particle(int id, Vec2 around, bool place, Vec2 *found);
    bool push_leg(int id, Vec2 end_A, bool slow_end);
    bool locate(PlanItem &item, bool place, Vec2 *at);
    void place_particle(PlanItem &item, Vec2 site);
    void check_disturbed(const std::vector<particle_t> &before, Vec2 drift_before, int pushed_id);
    void clear_blockers(const std::vector<int> &assigned);
    void run_particles();
    void replace_knocked_off();
    void register_at_end();
    void run_wires();
    // A rod's pushes towards its target (run_wires), one at a time.
    struct RodPushes {
        bool carrying = true;   // far from the target: turned and carried, not yet placed end by end
        Vec2 lastA, lastB;      // its ends before the last push
        int unmoved = 0;        // pushes in a row that left it where it was
    };
    struct RodPose;
    bool push_rod_once(const WireTargetSpec &t, PlanItem &item, RodPushes &st);
    RodPose rod_pose(const wire_t &w, const PlanItem &item, const WireTargetSpec &t) const;
    bool held_in_target_trench(const wire_t &w, const RodPose &p) const;
    void rod_end_errors(const RodPose &p, RodPushes &st, double *eA, double *eB) const;
    std::string rod_refusal(const wire_t &w, const RodPose &p, const PlanItem &item, RodPushes &st) const;
    bool push_wire_end(int wire_id, bool end_b, double dn_nm);
    struct EndGains { double a = 0, b = 0; bool ok = false; };
    EndGains end_gains(const wire_t &w, double l_nm) const;
    bool rod_model(const wire_t &w, fw_wire_t *rod) const;   // the card's rod with the trenches' hold
    void check_rod_by_scan(PlanItem &item, const WireTargetSpec &t);
};

}  // namespace afm
