// Contact mechanics as named models (physics.md section 13): the elastic,
// adhesive contact of a sphere on a flat or on a sphere (Hertz, DMT, JKR)
// and of a cylinder lying on a flat (line), friction from the model's area,
// a capillary meniscus, the Tabor parameter, and a quasi-static retraction
// that measures the pull-off force. A library: the world's step does not
// use it yet.
//
// Units (SI-consistent, no conversion inside a formula): lengths nm, forces
// nN, moduli GPa, since 1 GPa = 1 nN/nm^2 (1 GPa * 1 nm^2 = 1 nN); work of
// adhesion and surface tension mJ/m^2 = mN/m, 1 mN/m = 1e-3 nN/nm (so
// pi W R with W in mJ/m^2 and R in nm is 1e-3 pi W R nN); shear strength
// MPa, 1 MPa = 1e-3 GPa = 1e-3 nN/nm^2 (so 1 MPa * 1 nm^2 = 1e-3 nN);
// stiffness nN/nm = N/m. E* is the contact modulus,
// 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2; R the effective radius,
// 1/R = 1/R1 + 1/R2 (a flat: R2 infinite).
//
// The models (N the load, positive pressing; a the contact radius; delta the
// indentation; W the work of adhesion):
// - hertz: N = 4 E* a^3 / (3 R), delta = a^2 / R; no adhesion (W unused and
//   must be 0: a pair with W > 0 is refused, so that no key does nothing).
// - dmt:   N = 4 E* a^3 / (3 R) - 2 pi W R, delta = a^2 / R (Derjaguin,
//   Muller & Toporov 1975): the adhesion acts outside the contact.
// - jkr:   N = 4 E* a^3 / (3 R) - sqrt(8 pi W E* a^3),
//          delta = a^2 / R - sqrt(2 pi W a / E*) (Johnson, Kendall & Roberts
//          1971): the adhesion acts inside the contact, a neck at its edge.
// - line:  a cylinder of radius R and length L on a flat, per unit length
//          N' = N / L = pi E* b^2 / (4 R) - sqrt(2 pi E* W b), b the contact's
//          half-width (Johnson 1985 ch. 4, b = sqrt(4 N' R / (pi E*)) at
//          W = 0; with adhesion the plane-strain JKR, Barquins 1988,
//          Chaudhury et al. 1996). A plane-strain indentation has no absolute
//          datum: delta is the Hertzian part's approach
//          (b^2 / (4 R)) (2 ln(4R/b) - 1) (Johnson 1985's approach of a
//          cylinder's centre, with E*), a convention for ordering and
//          for the stiffness, not a depth to compare with a measurement.
// Pull-off (closed forms, load control): hertz 0, dmt 2 pi W R,
// jkr 1.5 pi W R, line 1.5 (pi E* W^2 R / 2)^(1/3) L. `retract` measures
// it instead, by following the model's equilibrium branch.
//
// Out of range: every input is checked (finite, inside the ranges below);
// a violation throws InputError with one line naming the field and value.
// A load at or below the pull-off (hertz: at or below 0) is no contact:
// Contact::in_contact false, a = delta = area = stiffness = 0, never NaN. A
// load whose contact would be wider than the sphere or cylinder (a > R) is
// refused (no model holds there); a > R/10 is answered but flagged
// (Contact::beyond_small_strain: Hertz's small-strain assumption fails).
#pragma once

#include <string>
#include <vector>

namespace afm::sim::contact {

// The ranges every input is checked against (inclusive).
constexpr double kMaxModulusGPa = 1e4;        // E, E*: (0, 1e4] (diamond is 1.2e3)
constexpr double kMinModulusGPa = 1e-6;       // 1 kPa, a soft gel
constexpr double kMaxRadiusNm = 1e9;          // R, L: (0, 1 m]
constexpr double kMaxWorkOfAdhesion = 1e4;    // W: [0, 1e4] mJ/m^2
constexpr double kMaxLoadNn = 1e15;           // |N| <= 1 MN
constexpr double kSmallStrain = 0.1;          // a / R beyond which beyond_small_strain is set

enum class Model { hertz, dmt, jkr, line };

// "hertz", "dmt", "jkr", "line": the scene's names for the models.
const char *model_name(Model m);
// The model of a name; InputError naming the name and the list otherwise.
Model model_from_name(const std::string &name);

// A material's elastic constants and its surface energy (the dispersive
// part, in air), the documented defaults of the table in contact_models.cpp.
struct Material {
    const char *name;
    double E_GPa;
    double nu;
    double surface_energy_mJ_m2;
};
const std::vector<Material> &materials();
// The material of a name; InputError naming the name and the list otherwise.
const Material &material(const std::string &name);

// Contact modulus E* (GPa) of two materials; checks each E and nu
// (nu in (-1, 0.5]).
double contact_modulus_GPa(double E1_GPa, double nu1, double E2_GPa, double nu2);
// Effective radius (nm) of two spheres; a flat is R2 = infinity.
double effective_radius_nm(double R1_nm, double R2_nm);
// Work of adhesion from two surface energies, W = 2 sqrt(g1 g2) (mJ/m^2;
// the Berthelot combination, Israelachvili 2011).
double work_of_adhesion_mJ_m2(const Material &a, const Material &b);

// One contacting pair: what every model reads.
struct Pair {
    double E_star_GPa = 0;   // contact modulus
    double R_nm = 0;         // effective radius (line: the cylinder's radius)
    double W_mJ_m2 = 0;      // work of adhesion
    double length_nm = 0;    // line: the cylinder's length in contact (else unused)
};
// A pair of two materials (E* from both) with the given radius and W;
// checks them all.
Pair make_pair(const Material &a, const Material &b, double R_nm, double W_mJ_m2, double length_nm = 0);
// Checks a pair for a model (ranges above; hertz: W = 0; line: L > 0).
void check_pair(Model m, const Pair &p);

// The state of a contact at a load.
struct Contact {
    bool in_contact = false;       // false at or below the pull-off
    double load_nN = 0;            // the load asked for
    double a_nm = 0;               // contact radius (line: half-width b)
    double delta_nm = 0;           // indentation (line: the convention above)
    double area_nm2 = 0;           // pi a^2 (line: 2 b L)
    double stiffness_nN_per_nm = 0;   // dN/d(delta) on the branch (jkr: 0 at the pull-off)
    bool beyond_small_strain = false; // a > 0.1 R
};
// The contact at load N (nN) on the model's stable branch, by bisection on
// the model's N(a) (the closed forms a(N) are not used here: the tests hold
// this against them).
Contact solve(Model m, const Pair &p, double load_nN);
// The closed form of the pull-off force under load control, nN, as a
// magnitude (the load at separation is its negative).
double pull_off_nN(Model m, const Pair &p);

// Tabor's parameter mu_T = (R W^2 / (E*^2 z0^3))^(1/3), z0 the equilibrium
// separation (nm, default 0.3), and the model it points to (Johnson &
// Greenwood 1997's adhesion map): "dmt" below 0.1, "jkr" above 5, "maugis"
// between (neither limit is exact there; Maugis 1992).
struct Tabor {
    double mu = 0;
    const char *apt = "";
};
Tabor tabor(const Pair &p, double z0_nm = 0.3);

// Friction F = mu N + tau A with A the model's area: mu_static while the
// contact sticks, mu_kinetic while it slides; tau in MPa (tau A in nN is
// 1e-3 tau_MPa A_nm2). Floored at 0 (a tensile load's mu N < 0 can cancel
// the area term, never reverse it); 0 out of contact.
struct Friction {
    double mu_static = 0;
    double mu_kinetic = 0;
    double tau_MPa = 0;
};
double friction_nN(const Friction &f, const Contact &c, bool sliding);

// How a retraction is driven: the load itself (load), the indentation
// (displacement: an infinitely stiff spring), or the base of a spring of
// stiffness k (spring).
enum class Control { load, displacement, spring };
struct Retraction {
    double min_force_nN = 0;   // the least (most tensile) contact force reached: the pull-off, negative
    double jump_force_nN = 0;  // the contact force at the last equilibrium before the jump off
    double jump_a_nm = 0;      // the contact radius there
    int steps = 0;             // control steps taken
};
// Retracts quasi-statically from the contact at start_load_nN (in contact):
// the control decreases in steps (a thousandth of the span of the control
// over the starting contact), the contact radius follows the stable branch
// (the first root below the last one), and when no root is left the last
// step is bisected to the edge. The line model only under load control
// (its indentation has no datum). InputError for a start out of contact or a
// spring stiffness not in (0, 1e6] nN/nm with Control::spring.
Retraction retract(Model m, const Pair &p, double start_load_nN, Control control, double spring_nN_per_nm = 0);

// The optional capillary model ("capillary"): a water meniscus between a
// sphere of radius R and a flat, both wetted at contact angle theta, in
// equilibrium with the vapour at relative humidity RH. Its Kelvin radius
// r_K = lambda_K / ln(1/RH) (lambda_K = gamma V_m / (R_g T) = 0.54 nm for
// water at 20 C) limits it: with the bodies held a gap D apart (surface
// asperities), the Laplace pressure gamma / r_K over the wetted area gives
// F = 4 pi R gamma cos(theta) (1 - D / (2 r_K cos(theta))) for
// D < 2 r_K cos(theta), else 0 (Israelachvili 2011, the sphere-flat
// meniscus; r_K << R, theta the same on both). At D = 0 it is
// 4 pi R gamma cos(theta) at any RH > 0; no meniscus at RH = 0 or
// theta >= 90 deg. The force pulls the bodies together: a caller adds it to
// the load. Ranges: RH [0, 1], theta [0, 180) deg, D [0, 100] nm.
constexpr const char *kCapillaryModel = "capillary";
constexpr double kWaterSurfaceTension_mN_m = 72.8;   // 20 C (CRC Handbook)
constexpr double kWaterKelvinLength_nm = 0.538;      // gamma V_m / (R_g T), 20 C: 0.0728 * 18.02e-6 / (8.314 * 293.15) m
struct Capillary {
    double RH = 0;            // relative humidity, 0..1
    double theta_deg = 0;     // water's contact angle on both surfaces
    double gap_nm = 0.3;      // the bodies' separation at contact (asperities)
};
double capillary_force_nN(double R_nm, const Capillary &c);

}  // namespace afm::sim::contact
