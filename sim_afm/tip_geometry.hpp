// Where the tip touches, in three dimensions (physics.md section 14): the
// gap, the contact points and the contact normal between the tip and a
// sphere (a particle), a finite cylinder (a rod, a wire's segment) or the
// substrate's height field. World's step takes a wire's contact normal from
// it (cylinder, through lift_off_push) for the tip's lift-off and the
// cone's press; the other queries are a library.
//
// The tip: a cone of half angle gamma whose spherical apex of radius R is
// tangent to it (the imaging's tip_profile, in 3-D), unbounded above (the
// paper's tip is 17.3 um high; TipContact::axial_nm says how high on the
// tip a contact lies, for the caller to hold against the tip height).
// gamma in [0, pi/2] (0: a cylinder of radius R with a hemispherical end;
// pi/2: the plane tangent to the apex), R >= 0 (0: a sharp cone), both
// finite; anything else is refused with std::invalid_argument naming the
// value. The scene's probe holds gamma in (0, 80] deg.
//
// Where an object resting on the substrate is first touched
// (TipGeometry::resting_reach_nm): the horizontal distance from the apex,
// standing on the plane z = apex's z, to the centre of a ball of radius r
// resting on that plane (or to the axis of a horizontal cylinder of radius
// r lying square to the approach), at which their gap is 0: where the
// cone's flank meets large objects first (the world's contacts still take
// the apex's circle, R + r: world_contact.cpp, init_reach).
//
// Frames and units: nm, rad. Every point is in one Cartesian frame whose
// xy plane is frame A's (or the sample's; the caller picks, the library
// only needs one) and whose z is up. The tip's axis points from the apex
// up into the tip: (0, 0, 1) turned by TipPose's angles, in this order:
// tilt about -y of the lever's frame C (positive swings the apex to +x_C,
// as Lever::bend_slope does), then twist about +x_C (positive swings the
// apex to +y_C, as Lever::twist), then alpha about z (C -> A, Lever::alpha).
//
// Every contact answers with a TipContact: gap_nm (signed distance between
// the two bodies' surfaces: positive apart, negative overlapping, then the
// depth of the object's deepest point inside the tip, measured to the tip's
// surface), the nearest points on the tip and on the object, the unit normal
// pointing from the object to the tip (a repulsive force on the tip acts
// along it), and which part of the tip it touches. The tip's signed distance
// is exact in closed form (TipGeometry::nearest, in the plane through the
// axis); on the axis, where the radial direction is undefined, the tip
// frame's x axis is taken as radial, so the normal is always a unit vector.
#pragma once

#include <Eigen/Dense>

#include <functional>

#include "lever.hpp"
#include "scene.hpp"

namespace afm::sim {

enum class TipPart { apex, flank };   // the apex's sphere, or the cone's flank above its tangent circle

struct TipContact {
    double gap_nm = 0;                 // signed: > 0 apart, < 0 overlapping
    Eigen::Vector3d on_tip_nm = Eigen::Vector3d::Zero();
    Eigen::Vector3d on_object_nm = Eigen::Vector3d::Zero();
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();   // unit, object -> tip
    TipPart part = TipPart::apex;
    double axial_nm = 0;               // on_tip's height above the apex along the axis
};

// The tip's place: its apex (the lowest point along its axis) and the
// lever's angles (header: their order and signs), rad, finite.
struct TipPose {
    Eigen::Vector3d apex_nm = Eigen::Vector3d::Zero();
    double tilt_rad = 0, twist_rad = 0, alpha_rad = 0;
};

// A substrate: its height (nm, finite) at a point of the xy plane (nm),
// e.g. a lambda around RoughSurface::height or MeasuredSurface::height. It
// may be discontinuous (a step); the tip meets the solid below it.
using HeightField = std::function<double(const Eigen::Vector2d &)>;

// How TipGeometry::height_field searches (the tolerance is stated there).
struct HeightSearch {
    double radius_nm = 50.0;   // around the apex's xy: the disc where contact is sought, [0, 1024 pitch]
    double pitch_nm = 1.0;     // the samples' spacing: finer than the field's narrowest feature, > 0
    double tol_nm = 1e-6;      // the last refining step, (0, pitch]
    int starts = 2;            // coarse minima refined (distinct basins), [1, 16]
};

class TipGeometry {
public:
    // Throws std::invalid_argument (one line: the field and its value) out
    // of the ranges in the file's header.
    TipGeometry(double radius_nm, double half_angle_rad, const TipPose &pose);
    // The scene's probe: tip_radius_nm and tip_half_angle_deg.
    static TipGeometry from_probe(const ProbeSpec &probe, const TipPose &pose);

    const Eigen::Vector3d &apex() const { return apex_; }
    const Eigen::Vector3d &axis() const { return axis_; }          // unit, apex -> into the tip
    const Eigen::Vector3d &apex_centre() const { return centre_; }   // apex + R axis
    double radius_nm() const { return r_; }
    double half_angle_rad() const { return gamma_; }

    // The tip's signed distance at q (nm; exact, negative inside), the
    // outward unit normal of the tip's surface at the point nearest q, and
    // the part that point lies on. Convex in q (the tip is convex), so the
    // cylinder's minimisation has one basin.
    struct Nearest {
        double sd_nm;
        Eigen::Vector3d outward;
        TipPart part;
    };
    Nearest nearest(const Eigen::Vector3d &q) const;

    // A sphere: centre and radius (>= 0, finite). Exact.
    TipContact sphere(const Eigen::Vector3d &centre_nm, double radius_nm) const;
    // A finite cylinder from a to b with hemispherical ends (the segment
    // swept by a ball of the radius: the planar model's stadium outline, and
    // a wire's segments join without gaps). Exact when the apex touches
    // (segment-point distance); on the flank, the closest point of the
    // axis is found by bisection on the sign of the gap's derivative along
    // it (the gap is convex along the segment), to the last bit of the
    // parameter (gap within 1e-9 nm on segments up to 1e5 nm). Where the
    // segment runs parallel to a generator the gap is flat along it and the
    // point returned is the flat stretch's end towards b. |b - a| below
    // 1e-9 nm: the sphere at a.
    TipContact cylinder(const Eigen::Vector3d &a_nm, const Eigen::Vector3d &b_nm, double radius_nm) const;
    // The reach (header): along the horizontal unit direction dir (frame's
    // xy), the least s >= 0 at which the ball of radius r centred at
    // apex + (s dir, r) (cylinder false), or the cylinder of radius r whose
    // axis runs through that point square to dir in the horizontal
    // (cylinder true; its half length half_length_nm), no longer overlaps
    // the tip: the gap's root, by bisection to 1e-9 nm (the gap is convex
    // along the line and negative at s = 0 for r > 0). r = 0: 0. Throws
    // std::invalid_argument for r or the half length not finite and >= 0
    // (> 0 for the half length), dir not a unit vector, or no reach below
    // 1e9 nm (gamma at 90 deg: the tip's plane overlaps any resting object).
    double resting_reach_nm(double radius_nm, const Eigen::Vector2d &dir, bool cylinder, double half_length_nm = 1e6) const;
    // The substrate: the least signed distance of a surface point
    // (x, y, z(x, y)) to the tip, over the search disc about the apex's xy.
    // Found numerically, in polar coordinates about that point: along each
    // ray, samples every pitch_nm out to the radius, and from each of the
    // `starts` best in distinct basins (no two within 2 samples) grids of 9
    // points, of half side twice the last step, the step halving until it
    // is below tol_nm; over the rays (at most a pitch apart at the rim) the
    // same, to tol_nm of arc at the rim. A step or an edge in any direction
    // is thus found in one dimension. The gap then lies within about
    // (1 + |grad z|) tol_nm of the least over the basins found; a basin
    // narrower than the pitch may be missed. Along an edge, where the gap
    // is flat to second order, the point is found to about sqrt(2 tol r)
    // and the normal to sqrt(2 tol / r) (r: the tip's radius of curvature
    // there; 1.6e-4 for tol 1e-6 nm on a flank 78 nm in radius). Cost: about 2 pi radius / pitch
    // rays of radius / pitch + 8 starts log2(pitch / tol) heights each, and
    // 8 starts log2(pitch / tol) more rays. The normal is the tip's geometry
    // at that point: the surface's normal where the field is smooth, the
    // direction from an edge to the tip at an edge. Throws
    // std::invalid_argument for a search out of range or a non-finite height.
    TipContact height_field(const HeightField &z, const HeightSearch &search = {}) const;

private:
    // The contact of a ball of radius r about q (the object's nearest point
    // to the tip; r = 0 for a surface point) with the tip.
    TipContact contact_at(const Eigen::Vector3d &q, double r) const;
    // The cylinder's flank search: the parameter of a-b whose point lies
    // nearest the tip (bisection on the derivative's sign).
    double segment_nearest(const Eigen::Vector3d &a, const Eigen::Vector3d &d) const;

    double r_, gamma_, sin_g_, cos_g_;
    Eigen::Vector3d apex_, axis_, e1_, centre_;   // e1_: the tip frame's x, the radial fallback on the axis
};

// The tip's vertical balance against a cylinder it pushes (physics.md 7,
// "The tip's lift-off"): the contact's force on the tip lambda n (n the
// contact normal from the 3-D geometry, object -> tip) lifts it by
// lambda n_z and pushes it back by lambda |n_h|; the apex leaves the
// substrate when lambda n_z exceeds lift_nN (the load plus the tip's
// adhesion), so the most it pushes horizontally is
// H = lift_nN |n_h| / n_z. The tip's pose follows the push: the lever's
// tilt (Lever::bend_slope) and twist (Lever::twist) under the force of the
// sample on the tip, -(H + friction_nN) along the motion (frame A) and the
// load; H is the fixed point of that balance (iterated from the upright
// tip's, to 1e-9 nN or 32 steps). The apex stands at (apex_xy, 0), the
// cylinder's axis a-b at the height the caller gives it (its radius on a
// flat); the normal at the apex's place (the caller's contact in the plane
// puts it at the resting reach: gap 0 for an upright tip, and a small
// overlap's nearest point otherwise). n_z <= 0 (the object presses the tip
// down): no lift, infinity; |n_h| = 0 (the apex above the axis): 0.
struct LiftOff {
    double push_nN = 0;
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();   // at the answer's pose
    TipPart part = TipPart::apex;
    int iterations = 0;
};
struct LiftInput {
    double radius_nm = 0, half_angle_rad = 0;   // the tip's (ProbeSpec)
    Eigen::Vector2d apex_xy = Eigen::Vector2d::Zero();
    Eigen::Vector2d motion = Eigen::Vector2d::UnitX();   // unit, frame A: the push's direction
    Eigen::Vector3d a = Eigen::Vector3d::Zero(), b = Eigen::Vector3d::UnitX();   // the cylinder's axis, nm
    double cylinder_radius_nm = 0;
    double load_nN = 0;      // F_z on the tip (its pose's bend)
    double lift_nN = 0;      // load plus the tip's adhesion: what the push must lift
    double friction_nN = 0;  // the tip's own sliding friction along the motion (its twist)
};
LiftOff lift_off_push(const Lever &lever, const LiftInput &in);

}  // namespace afm::sim
