// Nanowires on the substrate, pushed by the tip (physics.md sections 6, 8).
//
// Both models take the wire-substrate Coulomb friction as distributed along
// the wire and find the quasi-static motion from it; the closed forms of
// section 6 are what the tests check them against.
//
// - RigidWire (no wire_flexibility): a rod of length L with friction density
//   f (nN/nm). A push of the tip at a point of the axis moves it by the rigid
//   motion (twist) that the principle of maximum dissipation selects: among
//   the twists that move the contact point by a unit step along the push,
//   the one with the least friction power D. Its stationarity is force AND
//   torque balance of the push against the integrated friction (the Lagrange
//   multiplier is the push force, D itself, since D is 1-homogeneous).
//   Uniform friction (no trench holds any of the rod): rod_push_twist_uniform
//   integrates the friction exactly, in closed form: eq. 20 for a push
//   perpendicular to the axis, Newton's method on the exact D for an oblique
//   push (an end cap's contact). A trench under part of the rod makes the
//   friction anisotropic there: rod_push_twist lumps it on K points along the
//   axis and solves by iteratively reweighted least squares (a 3 x 3 system
//   per iteration), warm-started. Near the middle the rotation centre goes to
//   the rod's end, and at the middle to pure translation, without any
//   division by (l - s).
// - FlexibleWire (wire_flexibility): N segments (N + 1 nodes), stretch springs
//   (EA / segment length), discrete bending EI / (2 ds^3) |x_{i-1} - 2 x_i +
//   x_{i+1}|^2 (= EI / (2 ds) theta^2 for small joint angles theta), and Coulomb
//   friction f ds on each node (half at the ends). Each push (each sample's
//   pushes, between begin_step and end_step) the wire takes
//   the incremental quasi-static step: minimise elastic energy + tip contact
//   energy + sum_i c_i |x_i - x_i(start)| (rate-independent friction
//   dissipation, regularised below 1e-6 nm) until every node's force
//   balance holds to 1e-5 c_i (at most max_iterations Newton steps; the
//   next push resumes). The iterates: a first guess (the last increment,
//   scaled to the apex's advance when the wire keeps sliding; else, after
//   a test of balance at the start, scaled to the energy's minimum along
//   it), one step with the last factorisation of H (kept only if it
//   passes Armijo's test), then Newton steps with an Armijo line search.
//   H is block-pentadiagonal (2 x 2 blocks: a node couples to two
//   neighbours each side); each Newton step factors it as L D L^T by
//   blocks, O(N), shifted (Levenberg) when it is singular (no friction:
//   the rigid motions cost nothing). The unknowns are the step's
//   increments from its start, and the energy is the step's change of it
//   (each segment's and bend's from its start, taken once a step), so the
//   forces round as the increments do, not as the coordinates: at N = 1024
//   on a 5 um wire the bending stiffness EI / ds^3 times the coordinates'
//   rounding is past the tolerance. Every pass of a step is O(N); the
//   Newton steps a push takes (evaluations, newton_steps: the work) are
//   what can grow with N. The tip's contact is one point: the
//   closest point of the axis, shared by that segment's two nodes, so the
//   load does not depend on the mesh.
//
// Geometry: frame A (sample frame: the World adds drift), nm; forces nN.
#pragma once

#include <Eigen/Dense>

#include <algorithm>
#include <functional>
#include <limits>
#include <vector>

namespace afm::sim {

// Whether a trench holds a wire of diameter d at point p (sample frame): if
// so, the trench's direction there and how many times the friction across it
// exceeds the friction along it. Set only when the scene cuts trenches.
using TrenchTrap = std::function<bool(const Eigen::Vector2d &p, double d_nm, Eigen::Vector2d &along, double &hold)>;

// A twist of a rod in its own frame: velocity (vt along the axis, vn normal to
// it) of the rod's centre and angular rate omega, per unit of push travel.
struct RodTwist {
    double vt = 0, vn = 1, omega = 0;
    double force_nN = 0;     // the push that keeps it moving: the least friction power D
    int iterations = 0;
};

// Least-dissipation twist of a rod whose friction is lumped at axial positions
// u_k (from the centre, nm) with weight w_nN each, pushed at axial position u_p
// along the unit direction p = (p_t, p_n) of the rod frame. `warm` seeds the
// iteration. The iteration stops when a step changes the twist by at most
// `tol` of its size (force and torque balance then hold to about that,
// relative), or after max_iter iterations (the last iterate is returned).
// `metric` (optional, one per point): the point's friction power is
// w |G_k v_k| instead of w |v_k| (anisotropic friction, e.g. in a trench).
// w = 0 (no friction): the twist is the translation along p, force 0.
RodTwist rod_push_twist(const std::vector<double> &u_nm, double w_nN, double u_p_nm, const Eigen::Vector2d &p,
                        const RodTwist &warm, double tol = 1e-12, int max_iter = 500,
                        const std::vector<Eigen::Matrix2d> *metric = nullptr);

// The same least-dissipation twist for a rod of length L_nm whose friction
// density f (nN/nm) is uniform along it, integrated exactly (no friction
// points), pushed at axial position u_p (from the centre, nm; clamped to the
// rod) along the unit direction p of the rod frame.
// - |p_t| <= kRodPerpendicular (a side push, up to rounding): the closed
//   form, eq. 20 (iterations 0): rotation about the static point, or pure
//   translation at f L when |u_p| <= kRodMiddle L (the bifurcation; the
//   contact point's own rounding must not pick a side).
// - otherwise (an end cap's contact): Newton's method on the exact friction
//   power over the plane of twists that advance the contact point by one,
//   from `warm` (or the side push's twist, or the translation along p; see
//   rod.cpp), with a backtracking line search (the projected gradient's
//   when Newton's direction fails it); stops when force and torque balance
//   hold to `tol` relative to the push, or after max_iter iterations (the
//   best iterate is returned).
// L_nm <= 0 or f <= 0: the translation along p, force f L (0).
RodTwist rod_push_twist_uniform(double L_nm, double f_nN_per_nm, double u_p_nm, const Eigen::Vector2d &p,
                                const RodTwist &warm, double tol = 1e-8, int max_iter = 50);

// A push counts as perpendicular to the rod when |p_t| is at most this (the
// contact normal of a side contact is perpendicular up to rounding).
constexpr double kRodPerpendicular = 1e-9;
// A perpendicular push within this fraction of L of the rod's middle
// translates it: the contact point's own rounding (of order 1e-16 of the
// coordinates, far below this on a um rod) must not choose which end the
// rod turns about.
constexpr double kRodMiddle = 1e-9;

// Closest point of the segment a-b to q: the parameter t in [0, 1].
double segment_param(const Eigen::Vector2d &a, const Eigen::Vector2d &b, const Eigen::Vector2d &q);

// A symmetric positive (semi)definite system H x = r whose unknowns come in
// pairs (a node's x and y) and couple to two pairs either side: 2 x 2
// blocks H(i, i), H(i, i-1), H(i, i-2) (the flexible wire's Newton system).
// factor() computes H + shift I = L D L^T by blocks in O(n); solve() then
// applies its inverse. Each pivot block D_i is kept symmetric, as (a, b,
// 1/a, 1/det) with b the mean of the two off-diagonal entries rounding
// leaves it: with both, the asymmetry grows from pivot to pivot, and on a
// long chain of sliding nodes (whose friction holds them along their slip
// with next to nothing) it swamps the solve (test_flexible_wires checks the
// backward error on such chains).
class BlockPentadiagonal {
public:
    void resize(int n);                       // n pairs, blocks zeroed
    int size() const { return static_cast<int>(diag.size()); }
    std::vector<Eigen::Matrix2d> diag, sub1, sub2;   // H(i, i) (symmetric), H(i, i-1), H(i, i-2)
    // Factors H + shift I (shift >= 0). False when a pivot is not positive:
    // a block's pivots a and det / a at most kPivot of its trace (H singular
    // to rounding, or indefinite); solve() must not be used then.
    bool factor(double shift);
    void solve(std::vector<Eigen::Vector2d> &r) const;   // r := (H + shift I)^-1 r, r of size()
    // Rounding in the elimination of an n-pair chain is about n 1e-16 of a
    // block's trace; a pivot below kPivot of it counts as zero.
    static constexpr double kPivot = 1e-13;

    struct Pivot {                            // D = [a b; b c] as (a, b, 1/a, 1/det D)
        double a = 1, b = 0, inv_a = 1, inv_det = 1;
    };

private:
    std::vector<Eigen::Matrix2d> l1_, l2_;   // L(i, i-1), L(i, i-2)
    std::vector<Pivot> piv_;                 // D_i
};

// The tip's contact with a polyline of capsules (segments of half width
// d/2 with round caps), as features: each segment whose closest point to
// the apex is inside it, and each node whose count is not zero: +1 for a
// node that is both its segments' closest point (the convex side of a
// bend, or an end), -1 for an inner node that neither is (the concave
// side: the two segments' terms would count its share twice). Their
// energies sum, by inclusion-exclusion of the shared caps, to one contact
// wherever a single segment or node is closest, and to the blend of both
// segments (and the node taken off) where the apex faces a bend's inside:
// continuously differentiable in the apex and in the nodes, so the force's
// direction turns smoothly across a node instead of jumping between the
// segments' normals (physics.md 5.1). Only features closer than the reach
// are listed.
struct ContactFeature {
    int a = 0;               // the segment (a, a + 1), or the node a
    bool node = false;
    double t = 0;            // along the segment (0 for a node)
    double sign = 1;         // its count: +1, or -1 (an inner node on a bend's inside)
    double dist = 0;         // from the apex to the feature, nm
    Eigen::Vector2d n = Eigen::Vector2d::Zero();   // unit, from the feature to the apex
};

// The features of segments lo..hi of xs within `reach` of q (appended to
// out). A node of the window's edge counts as an end (the window must hold
// every segment within reach). n0: the normal when the apex is on a node.
void contact_features(const Eigen::Vector2d *xs, int lo, int hi, const Eigen::Vector2d &q, double reach,
                      const Eigen::Vector2d &n0, std::vector<ContactFeature> &out);

// The tip's push through a wire's contact (Wire::tip_push): the force on
// the apex, nN, and its stiffness with the wire held (-dF/dq, nN/nm:
// k n n^T for each feature, less the turning of a node's normal).
struct TipPush {
    Eigen::Vector2d force = Eigen::Vector2d::Zero();
    Eigen::Matrix2d stiffness = Eigen::Matrix2d::Zero();
};

class Wire {
public:
    virtual ~Wire() = default;
    int id = 0;
    double d_nm = 100;            // diameter
    double L_nm = 0;              // length
    bool in_contact = false;
    // Nodes along the axis, frame A of the sample (2 for a rigid rod).
    const std::vector<Eigen::Vector2d> &nodes() const { return x; }
    // Bounding box of the axis, nm (for cheap rejection).
    Eigen::Vector2d lo, hi;
    // Whether the apex circle (centre q, radius r) may touch the footprint.
    bool near(const Eigen::Vector2d &q, double r) const
    {
        const double m = r + 0.5 * d_nm;
        return q.x() > lo.x() - m && q.x() < hi.x() + m && q.y() > lo.y() - m && q.y() < hi.y() + m;
    }
    // Contact with the apex circle (centre q, radius r_tip): penetration into
    // the footprint (half width d/2), nm (negative: apart), the unit normal
    // from the wire to the apex, and the arc position along the axis of the
    // closest point (nm from the first node; the first of equally close).
    // Returns false when not touching.
    bool contact(const Eigen::Vector2d &q, double r_tip, double &pen, Eigen::Vector2d &n_out, double &u_out) const;
    // The contact's multiplier, nN: the tip pushes the wire with
    // max(0, lambda + k pen) (an augmented Lagrangian on the penalty k; the
    // world's solver raises lambda by k pen each sweep, so at convergence
    // the contact is closed to kSolverGapTol_nm and its force does not
    // depend on k). 0 for a push on its own (the plain penalty).
    double lambda_nN = 0;
    double contact_force(double k, double pen) const { return std::max(0.0, lambda_nN + k * pen); }
    // The push on the apex circle (centre q, radius r_tip) with penalty k:
    // each contact feature (contact_features) pushes by max(0, lambda + k
    // pen) along its normal, times its count.
    TipPush tip_push(const Eigen::Vector2d &q, double r_tip, double k) const;
    // The tip at q pushes the wire with contact stiffness k (nN/nm): the wire
    // moves to quasi-static equilibrium. Returns true when it moved.
    // ride_nN: the most the tip can push before it leaves the substrate
    // (World::ride_push_nN, the tip's vertical balance); when the wire needs
    // more than that to move and the contact reaches it, the tip rides over:
    // `ridden`, and the wire stays.
    virtual bool push(const Eigen::Vector2d &q, double r_tip, double k_contact,
                      double ride_nN = std::numeric_limits<double>::infinity()) = 0;
    // One sample's step over several pushes (the world's contact solver,
    // World::relax): between begin_step() and end_step() every push solves
    // the same step, from the wire's place at begin_step() to balance with
    // the tip where it now is (resumed from the last push's answer), so the
    // force a push leaves is a function of the apex alone and the apex's
    // balance with it converges. Without begin_step() each push is a step.
    virtual void begin_step() {}
    virtual void end_step() {}
    // Whether the step's last push left the wire in balance to tol_nN (the
    // world's force tolerance): every node's force within it of its
    // Coulomb law (a rod's push is exact).
    virtual bool settled(double tol_nN) const { (void)tol_nN; return true; }
    // Distance from q to the wire's axis, nm.
    double axis_distance(const Eigen::Vector2d &q) const;
    TrenchTrap trap;              // empty unless lithography cuts trenches
    // down_force (physics.md 6-7, rigid rods): the push H presses the wire
    // by H tan psi, its friction rises by mu H tan psi; when k(l) mu tan psi
    // >= 1 (eq. 29's denominator) no push moves it: squeezed. Flexible
    // wires ignore it (their friction is per node, the press at one), and
    // so does a rod a trench holds (the walls carry the press).
    double mu = 0;                // wire-substrate mu (0: no down force)
    double press_tan = 0;         // n_z / |n_h| of the tip's contact normal this sample (tan psi on the flank)
    bool squeezed = false;        // the last push could not move it
    bool ridden = false;          // the last push: the tip rode over it (push's ride_nN), and it stayed
    bool pulled = false;          // the apex's balance took this wire's contact in this sweep (World::apex_pull)

protected:
    std::vector<Eigen::Vector2d> x;   // nodes, nm
    void update_box();
    mutable std::vector<ContactFeature> features_;   // tip_push's, kept (no allocation per call)
};

class RigidWire : public Wire {
public:
    // Ends a, b; friction density f (nN/nm); K friction points (they carry
    // the friction only where a trench holds the rod; uniform friction is
    // integrated exactly).
    RigidWire(int id, const Eigen::Vector2d &a, const Eigen::Vector2d &b, double d_nm, double f_nN_per_nm, int K);
    // Uniform friction by the lumped, iterative solver too (sample.wire.solver: numeric).
    bool numeric = false;
    bool push(const Eigen::Vector2d &q, double r_tip, double k_contact,
              double ride_nN = std::numeric_limits<double>::infinity()) override;
    void place(const Eigen::Vector2d &centre, double psi);   // sets the pose and the nodes
    void begin_step() override { in_step_ = true, metric_valid_ = false; }   // the trench's metric is kept within a step only
    void end_step() override { in_step_ = false, metric_valid_ = false; }

    Eigen::Vector2d centre;       // nm
    double psi = 0;               // axis angle from +x, rad
    RodTwist last;                // the last twist (for tests: rotation centre)
    int held_points = 0;          // friction points a trench held in the last push (0: uniform friction)
    double f = 0;                 // friction density, nN/nm
    std::vector<double> u;        // friction points, from the centre, nm (used where a trench holds the rod)

private:
    std::vector<Eigen::Matrix2d> metric_;
    bool in_step_ = false;                 // between begin_step and end_step
    bool metric_valid_ = false;            // metric_ is the trench's at metric_centre_, metric_psi_ (within a step)
    Eigen::Vector2d metric_centre_ = Eigen::Vector2d::Zero();
    double metric_psi_ = 0;
};

class FlexibleWire : public Wire {
public:
    // Ends a, b; N segments; at most `iterations` Newton steps a push.
    // Throws std::invalid_argument (naming the wire) when the segments have
    // no length (a = b, or N < 1).
    FlexibleWire(int id, const Eigen::Vector2d &a, const Eigen::Vector2d &b, double d_nm, double f_nN_per_nm,
                 double E_GPa, int segments, int iterations);
    bool push(const Eigen::Vector2d &q, double r_tip, double k_contact,
              double ride_nN = std::numeric_limits<double>::infinity()) override;
    void begin_step() override;
    void end_step() override;
    bool settled(double tol_nN) const override { return !open_ || last_converged || last_imbalance_nN <= tol_nN; }

    double ds = 0;                    // rest segment length, nm
    double EI = 0;                    // nN nm^2
    double ks = 0;                    // stretch stiffness EA / ds, nN/nm
    double f = 0;                     // friction density, nN/nm
    int max_iterations = 8;           // Newton iterations per push, at most
    int last_iterations = 0;          // the last push's Newton iterations (balance tests; 1: none needed)
    bool last_converged = false;      // whether it met the step tolerance
    double last_imbalance_nN = 0;     // the last push's worst node imbalance, nN (the Coulomb law's excess at a stuck node)
    long solved = 0;                  // steps the tip was in contact for (each solved to the step tolerance, or not)
    int worst_iterations = 0;         // the most Newton iterations one push took
    long unconverged = 0;             // steps left out of balance (a push at max_iterations that no later push of the step finished)
    long regularised = 0;             // Newton steps whose system was singular (solved with a Levenberg shift)
    long evaluations = 0;             // energy evaluations, all pushes (the work: each is O(N))
    long newton_steps = 0;            // Newton steps (each a factorisation), all pushes
    long full_steps = 0;              // Newton steps whose line search found no decrease (the whole step taken)

private:
    // The tip's contact during one push: apex q, reach r_tip + d/2, contact
    // stiffness kc, the segment closest to it at the push's start, the
    // window of segments lo..hi whose features (contact_features) it may
    // touch during the push, and the normal to use if the apex sits on the
    // axis.
    struct Contact {
        Eigen::Vector2d q, n0;
        int seg = 0, lo = 0, hi = 0;
        double reach = 0, kc = 0;
        double lam = 0;   // the multiplier (Wire::lambda_nN): the force is kc (pen + lam / kc)
    };
    // What one evaluation of the step's energy leaves for the Newton step at
    // that point: the gradient (nN), each segment's unit direction, each
    // node's friction stiffness c_i / s and direction dx / s (s =
    // sqrt(|dx|^2 + eps^2)), the contact's features and their forces on
    // the nodes (cg: zero outside the features' nodes).
    struct Eval {
        std::vector<Eigen::Vector2d> g, seg_dir, node_dir, cg;
        std::vector<double> node_w;
        double residual = 0;          // worst node's imbalance (a ratio of squares; < 1: balanced)
        double imbalance_nN = 0;      // the same, nN: a sliding node's net force, a stuck one's force past c_i
        std::vector<ContactFeature> feats;
    };
    std::vector<Eigen::Vector2d> last_dx_;   // the last push's increment (warm start)
    // The step's work arrays, kept between pushes (no allocation per push):
    // its start, the increments from it (the unknowns: the nodes are start_
    // + dx_), the start's segments, their lengths and its bends
    // (begin_increments), a line search's base and the Newton direction.
    std::vector<Eigen::Vector2d> start_, dx_, e0_, b0_, base_, dir_;
    std::vector<double> len0_;
    Eval now_, trial_;                                // at x; at a trial point
    bool factored_ = false;                           // H_ holds a factorisation
    BlockPentadiagonal H_;                            // the Newton system (its last factorisation)
    // Distance from q to the axis; the closest segment and its parameter.
    double closest(const Eigen::Vector2d &q, int &seg, double &t) const;
    double node_friction(int i) const;   // c_i = f ds, half at the ends, nN
    void contact_window(Contact &c) const;   // c.lo, c.hi about c.q and c.seg
    // evaluate()'s tip contact: its energy and the forces on its segment's nodes.
    static double contact_energy(const Contact &c, const Eigen::Vector2d *xs, Eval &ev);
    // The step's energy at start_ + dx_ (elastic + contact + regularised
    // friction work), less the elastic energy at its start, nN nm; fills ev
    // there (and places the contact window's nodes in x).
    double evaluate(const Contact &c, Eval &ev);
    void begin_increments();   // the step starts where the wire is: start_, e0_, len0_, b0_; dx_ zero
    void place_nodes();        // x := start_ + dx_, and the box
    // d^T H d of the elastic and contact energy at ev's point.
    double elastic_curvature(const Contact &c, const Eval &ev, const std::vector<Eigen::Vector2d> &d) const;
    void assemble_hessian(const Contact &c, const Eval &ev);   // into H_'s blocks
    void newton_direction();                   // dir_ := -H^-1 now_.g (Levenberg shift if H is singular)
    // x := base_ + alpha dir_ if that passes Armijo's test against phi
    // (then phi and now_ follow); false otherwise (x is left there).
    bool try_step(const Contact &c, double &phi, double alpha);
    // One Newton step from x (evaluated in now_) with an Armijo line search
    // on the energy phi; updates x, phi and now_.
    void newton_step(const Contact &c, double &phi);
    // A step with the last factorisation, kept only if it passes Armijo's
    // test (a steady push's H changes little from step to step).
    void chord_step(const Contact &c, double &phi);
    // The last step's increment, scaled to the energy's minimum along it,
    // as the starting point (x, phi, now_), when it lowers the energy.
    void warm_start(const Contact &c, double &phi);
    // The first guess of a steady slide (x, phi, now_): the last increment
    // scaled to the apex's advance; false (nothing done) when the last push
    // did not slide to balance or the apex did not advance into the wire.
    bool follow(const Contact &c, double t_seg, double &phi);
    Eigen::Vector2d last_q_ = Eigen::Vector2d::Zero();   // the apex at the last push
    bool stepping_ = false;   // begin_step() was called: pushes share a step until end_step()
    bool open_ = false;       // a step is under way: start_ is its start, the next push resumes it
    // The push's first guess: a fresh step's (follow, else a balance test
    // at the start and warm_start), or a resumed step's (x as it is).
    void first_guess(const Contact &c, double t_seg, bool resume, double &phi);
    void close_step();        // a step's counters; the stuck nodes back to their start
};

}  // namespace afm::sim
