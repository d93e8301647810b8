// Nanowires on the substrate, pushed by the tip (physics.md sections 6, 8).
//
// Both models integrate the wire-substrate Coulomb friction numerically; none
// of them uses the closed forms of section 6 (those are what the tests check
// them against).
//
// - RigidWire (no wire_flexibility): a rod of length L with friction density
//   f (nN/nm) lumped on K points along its axis. A push of the tip at a point
//   of the axis moves it by the rigid motion (twist) that the principle of
//   maximum dissipation selects: among the twists that move the contact point
//   by a unit step along the push, the one with the least friction power
//   D = sum_k f dL |v_k|. Its stationarity is force AND torque balance of the
//   push against the integrated friction (the Lagrange multiplier is the push
//   force, D itself, since D is 1-homogeneous). Solved by iteratively
//   reweighted least squares (a 3 x 3 system per iteration), warm-started.
//   Near the middle the rotation centre goes to the rod's end, and at the
//   middle to pure translation, without any division by (l - s).
// - FlexibleWire (wire_flexibility): N segments (N + 1 nodes), stretch springs
//   (EA / segment length), discrete bending EI / (2 ds^3) |x_{i-1} - 2 x_i +
//   x_{i+1}|^2 (= EI / (2 ds) theta^2 for small joint angles theta), and Coulomb
//   friction f ds on each node (half at the ends). Each push the wire takes
//   the incremental quasi-static step: minimise elastic energy + tip contact
//   energy + sum_i c_i |x_i - x_i(start)| (rate-independent friction
//   dissipation, regularised below 1e-6 nm) by Newton steps with an Armijo
//   line search on a banded system, until every node's force balance holds to
//   1e-5 c_i (at most max_iterations; the next push resumes). The tip's
//   contact is one point: the closest point of the axis, shared by that
//   segment's two nodes, so the load does not depend on the mesh.
//
// Geometry: frame A (sample frame: the World adds drift), nm; forces nN.
#pragma once

#include <Eigen/Dense>

#include <functional>
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
// iteration. Force and torque balance hold at the result to `tol` (relative).
// `metric` (optional, one per point): the point's friction power is
// w |G_k v_k| instead of w |v_k| (anisotropic friction, e.g. in a trench).
RodTwist rod_push_twist(const std::vector<double> &u_nm, double w_nN, double u_p_nm, const Eigen::Vector2d &p,
                        const RodTwist &warm, double tol = 1e-12, int max_iter = 500,
                        const std::vector<Eigen::Matrix2d> *metric = nullptr);

// Closest point of the segment a-b to q: the parameter t in [0, 1].
double segment_param(const Eigen::Vector2d &a, const Eigen::Vector2d &b, const Eigen::Vector2d &q);

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
    // the footprint (half width d/2) and the unit normal from the wire to the
    // apex. Returns false when not touching.
    bool contact(const Eigen::Vector2d &q, double r_tip, double &pen, Eigen::Vector2d &n_out, double &u_out) const;
    // The tip at q pushes the wire with contact stiffness k (nN/nm): the wire
    // moves to quasi-static equilibrium. Returns true when it moved.
    virtual bool push(const Eigen::Vector2d &q, double r_tip, double k_contact) = 0;
    // Distance from q to the wire's axis, nm.
    double axis_distance(const Eigen::Vector2d &q) const;
    TrenchTrap trap;              // empty unless lithography cuts trenches
    // down_force (physics.md 6-7, rigid rods): the push H presses the wire
    // by H tan psi, its friction rises by mu H tan psi; when k(l) mu tan psi
    // >= 1 (eq. 29's denominator) no push moves it: squeezed. Flexible
    // wires ignore it (their friction is per node, the press at one), and
    // so does a rod a trench holds (the walls carry the press).
    double mu = 0;                // wire-substrate mu (0: no down force)
    double press_tan = 0;         // tan psi of this sample's push
    bool squeezed = false;        // the last push could not move it

protected:
    std::vector<Eigen::Vector2d> x;   // nodes, nm
    void update_box();
};

class RigidWire : public Wire {
public:
    // Ends a, b; friction density f (nN/nm); K friction points.
    RigidWire(int id, const Eigen::Vector2d &a, const Eigen::Vector2d &b, double d_nm, double f_nN_per_nm, int K);
    bool push(const Eigen::Vector2d &q, double r_tip, double k_contact) override;
    void place(const Eigen::Vector2d &centre, double psi);   // sets the pose and the nodes

    Eigen::Vector2d centre;       // nm
    double psi = 0;               // axis angle from +x, rad
    RodTwist last;                // the last twist (for tests: rotation centre)
    double f = 0;                 // friction density, nN/nm
    std::vector<double> u;        // friction points, from the centre, nm

private:
    std::vector<Eigen::Matrix2d> metric_;
};

class FlexibleWire : public Wire {
public:
    FlexibleWire(int id, const Eigen::Vector2d &a, const Eigen::Vector2d &b, double d_nm, double f_nN_per_nm,
                 double E_GPa, int segments, int iterations);
    bool push(const Eigen::Vector2d &q, double r_tip, double k_contact) override;

    double ds = 0;                    // rest segment length, nm
    double EI = 0;                    // nN nm^2
    double ks = 0;                    // stretch stiffness EA / ds, nN/nm
    double f = 0;                     // friction density, nN/nm
    int max_iterations = 8;           // Newton iterations per push, at most
    int last_iterations = 0;          // the last push's Newton iterations
    bool last_converged = false;      // whether it met the step tolerance
    long unconverged = 0;             // pushes that hit max_iterations

private:
    std::vector<Eigen::Vector2d> last_dx_;   // the last push's increment (warm start)
    // Distance from q to the axis; the closest segment and its parameter.
    double closest(const Eigen::Vector2d &q, int &seg, double &t) const;
    // The step's energy: elastic + tip contact (on segment seg) +
    // regularised friction work from `start`.
    double energy(const std::vector<Eigen::Vector2d> &start, const Eigen::Vector2d &q, int seg, double reach,
                  double kc) const;
    void solve_banded(std::vector<double> &A, std::vector<double> &rhs) const;
};

}  // namespace afm::sim
