// Contact mechanics as named models (contact_models.hpp): each model's
// equilibrium relation N(a), delta(a) in one place (Branch), the solve by
// bisection on it, the retraction that follows it.

#include "contact_models.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "process.hpp"

namespace afm::sim::contact {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMilliToNanoNewtonPerNm = 1e-3;   // 1 mJ/m^2 = 1 mN/m = 1e-3 nN/nm
constexpr double kMPaToGPa = 1e-3;                 // 1 MPa = 1e-3 nN/nm^2

// The paper's materials (E GPa, nu, surface energy mJ/m^2 in air). The
// elastic constants are handbook values for the bulk material; the surface
// energies are those of a surface in laboratory air (adsorbed hydrocarbons
// and water bring a clean metal's or oxide's 1-2 J/m^2 down to the
// dispersive 40-60 mJ/m^2), so W from two of them is a few tens of mJ/m^2.
const std::vector<Material> kMaterials = {
    // Silicon, the tip: E along <110> 169 GPa, nu 0.27 (Hopcroft, Nix & Kenny,
    // J. MEMS 19, 229 (2010)); native oxide in air: the SiO2 value.
    {"silicon", 169.0, 0.27, 45.0},
    // Silicon nitride (LPCVD films, tips): 250-320 GPa reported, 290 taken,
    // nu 0.27; bulk Si3N4 is stiffer (385 GPa: Petersen, Proc. IEEE 70, 420
    // (1982)); in air about 45 mJ/m^2.
    {"silicon_nitride", 290.0, 0.27, 45.0},
    // Glass / SiO2 substrate: soda-lime glass 70 GPa, nu 0.22 (the scene's
    // glass, common/scene.cpp); fused silica 72 GPa, nu 0.17 (Corning 7980
    // data sheet). Silica in air, dispersive part: about 45 mJ/m^2.
    {"glass", 70.0, 0.22, 45.0},
    {"silica", 72.0, 0.17, 45.0},
    // Gold (particles): polycrystalline 79 GPa, nu 0.42 (CRC Handbook,
    // elastic constants of metals); in air about 50 mJ/m^2.
    {"gold", 79.0, 0.42, 50.0},
    // Silver (nanowires): polycrystalline 83 GPa, nu 0.37 (CRC Handbook; the
    // scene's wire modulus is sample.wire.youngs_modulus_GPa); in air about 50.
    {"silver", 83.0, 0.37, 50.0},
    // Polystyrene / latex particles: 3.4 GPa, nu 0.34; surface energy 40.7
    // mJ/m^2 at 20 C (Mark, Physical Properties of Polymers Handbook;
    // Wu, Polymer Interface and Adhesion, 1982).
    {"polystyrene", 3.4, 0.34, 40.7},
    // Polycarbonate (bisphenol A): 2.4 GPa, nu 0.37 (the scene's
    // polycarbonate, common/scene.cpp); 42.9 mJ/m^2 (Wu 1982).
    {"polycarbonate", 2.4, 0.37, 42.9},
};

std::string show(double v)
{
    std::ostringstream o;
    o << v;
    return o.str();
}

[[noreturn]] void refuse(const std::string &field, const std::string &want, double got)
{
    throw InputError("contact: " + field + " must be " + want + ", got " + show(got));
}

void check_range(const char *field, double v, double lo, double hi, bool lo_open)
{
    const bool ok = std::isfinite(v) && (lo_open ? v > lo : v >= lo) && v <= hi;
    if (!ok) refuse(field, std::string(lo_open ? "in (" : "in [") + show(lo) + ", " + show(hi) + "]", v);
}

void check_modulus(const char *field, double E_GPa) { check_range(field, E_GPa, kMinModulusGPa, kMaxModulusGPa, false); }

void check_poisson(const char *field, double nu) { check_range(field, nu, -1.0, 0.5, true); }

// One model's equilibrium relation, parametrised by the contact radius a
// (line: the half-width b), in nN and nm; E in nN/nm^2, W in nN/nm.
struct Branch {
    Model model;
    double E, R, W, L;

    Branch(Model m, const Pair &p)
        : model(m), E(p.E_star_GPa), R(p.R_nm), W(p.W_mJ_m2 * kMilliToNanoNewtonPerNm), L(p.length_nm) {}

    double force(double a) const
    {
        const double hertz = 4.0 * E * a * a * a / (3.0 * R);
        switch (model) {
        case Model::hertz: return hertz;
        case Model::dmt: return hertz - 2.0 * kPi * W * R;
        case Model::jkr: return hertz - std::sqrt(8.0 * kPi * W * E * a * a * a);
        case Model::line: return L * (kPi * E * a * a / (4.0 * R) - std::sqrt(2.0 * kPi * E * W * a));
        }
        return 0;
    }
    double delta(double a) const
    {
        switch (model) {
        case Model::hertz:
        case Model::dmt: return a * a / R;
        case Model::jkr: return a * a / R - std::sqrt(2.0 * kPi * W * a / E);
        case Model::line: return a > 0 ? a * a / (4.0 * R) * (2.0 * std::log(4.0 * R / a) - 1.0) : 0.0;
        }
        return 0;
    }
    // dN/d(delta) at a > 0, from dN/da and d(delta)/da.
    double stiffness(double a) const
    {
        switch (model) {
        case Model::hertz:
        case Model::dmt: return 2.0 * E * a;
        case Model::jkr: {
            const double dN = 4.0 * E * a * a / R - 1.5 * std::sqrt(8.0 * kPi * W * E * a);
            const double dd = 2.0 * a / R - 0.5 * std::sqrt(2.0 * kPi * W / (E * a));
            return dN / dd;
        }
        case Model::line: {
            const double dN = L * (kPi * E * a / (2.0 * R) - 0.5 * std::sqrt(2.0 * kPi * E * W / a));
            const double dd = a / R * (std::log(4.0 * R / a) - 1.0);
            return dN / dd;
        }
        }
        return 0;
    }
    // The radius where N(a) is least (the load-controlled pull-off): 0
    // without a neck (hertz, dmt).
    double fold() const
    {
        switch (model) {
        case Model::hertz:
        case Model::dmt: return 0.0;
        case Model::jkr: return std::cbrt(9.0 * kPi * W * R * R / (8.0 * E));
        case Model::line: return std::cbrt(2.0 * W * R * R / (kPi * E));
        }
        return 0;
    }
};

const char *const kNames[] = {"hertz", "dmt", "jkr", "line"};

// A retraction's control as a function of the contact radius: the load
// N(a), the indentation delta(a), or a spring's base k u = N(a) + k delta(a).
// The stable equilibrium for a control c is the root of held(a) = c where
// held rises with a; after a decrease of c it is the first root below the
// last one.
struct Follower {
    const Branch &b;
    Control control;
    double k;

    double held(double a) const
    {
        if (control == Control::load) return b.force(a);
        if (control == Control::displacement) return b.delta(a);
        return b.force(a) + k * b.delta(a);
    }
    // The first root of held(a) = c below a_prev (scanned down in 500
    // steps, then bisected); false when none is left down to a = 0.
    bool root(double c, double a_prev, double &a) const
    {
        const double h = a_prev / 500.0;
        for (double hi = a_prev; hi > 0.0;) {
            double lo = std::max(0.0, hi - h);
            if (held(lo) - c < 0.0) {
                for (int i = 0; i < 100 && hi - lo > 1e-14 * a_prev; ++i) {
                    const double mid = 0.5 * (lo + hi);
                    (held(mid) - c < 0.0 ? lo : hi) = mid;
                }
                a = 0.5 * (lo + hi);
                return true;
            }
            hi = lo;
        }
        return false;
    }
};

// The span of the held quantity over [0, a0] (64 samples): the scale of
// the control's steps.
double held_span(const Follower &f, double a0)
{
    double lo = f.held(a0), hi = lo;
    for (int i = 0; i < 64; ++i) {
        const double v = f.held(a0 * i / 64.0);
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    return hi - lo;
}

}  // namespace

Retraction retract(Model m, const Pair &p, double start_load_nN, Control control, double spring_nN_per_nm)
{
    if (control == Control::spring) check_range("spring_nN_per_nm", spring_nN_per_nm, 0.0, 1e6, true);
    if (m == Model::line && control != Control::load)
        throw InputError("contact: a line contact retracts only under load control (its indentation has no datum)");
    const Contact start = solve(m, p, start_load_nN);
    if (!start.in_contact)
        refuse("start_load_nN", std::string("above the ") + model_name(m) + " pull-off -" + show(pull_off_nN(m, p)) +
                                    " nN (a retraction starts in contact)", start_load_nN);
    const Branch b(m, p);
    const Follower f{b, control, spring_nN_per_nm};
    double a_good = start.a_nm, c_good = f.held(a_good);
    const double dc = held_span(f, a_good) / 1000.0;
    Retraction r;
    r.min_force_nN = b.force(a_good);
    double c_lost = c_good;
    for (;;) {   // step the control down until no equilibrium is left
        if (++r.steps > 1000000) throw std::runtime_error("contact: retract: no pull-off within 1e6 steps");
        const double c = c_good - dc;
        double a = 0;
        if (!f.root(c, a_good, a)) { c_lost = c; break; }
        a_good = a;
        c_good = c;
        r.min_force_nN = std::min(r.min_force_nN, b.force(a));
    }
    for (int i = 0; i < 60; ++i) {   // the edge of the branch, by bisection of the last step
        const double c = 0.5 * (c_good + c_lost);
        double a = 0;
        if (f.root(c, a_good, a)) {
            a_good = a;
            c_good = c;
            r.min_force_nN = std::min(r.min_force_nN, b.force(a));
        } else {
            c_lost = c;
        }
    }
    r.jump_force_nN = b.force(a_good);
    r.jump_a_nm = a_good;
    return r;
}

const char *model_name(Model m) { return kNames[static_cast<int>(m)]; }

Model model_from_name(const std::string &name)
{
    for (int i = 0; i < 4; ++i)
        if (name == kNames[i]) return static_cast<Model>(i);
    throw InputError("contact: unknown model '" + name + "' (hertz, dmt, jkr or line)");
}

const std::vector<Material> &materials() { return kMaterials; }

const Material &material(const std::string &name)
{
    std::string list;
    for (const auto &m : kMaterials) {
        if (name == m.name) return m;
        list += (list.empty() ? "" : ", ") + std::string(m.name);
    }
    throw InputError("contact: unknown material '" + name + "' (" + list + ")");
}

double contact_modulus_GPa(double E1_GPa, double nu1, double E2_GPa, double nu2)
{
    check_modulus("E1_GPa", E1_GPa);
    check_modulus("E2_GPa", E2_GPa);
    check_poisson("nu1", nu1);
    check_poisson("nu2", nu2);
    return 1.0 / ((1.0 - nu1 * nu1) / E1_GPa + (1.0 - nu2 * nu2) / E2_GPa);
}

double effective_radius_nm(double R1_nm, double R2_nm)
{
    check_range("R1_nm", R1_nm, 0.0, kMaxRadiusNm, true);
    if (std::isinf(R2_nm) && R2_nm > 0) return R1_nm;
    check_range("R2_nm", R2_nm, 0.0, kMaxRadiusNm, true);
    return R1_nm * R2_nm / (R1_nm + R2_nm);
}

double work_of_adhesion_mJ_m2(const Material &a, const Material &b)
{
    return 2.0 * std::sqrt(a.surface_energy_mJ_m2 * b.surface_energy_mJ_m2);
}

Pair make_pair(const Material &a, const Material &b, double R_nm, double W_mJ_m2, double length_nm)
{
    Pair p;
    p.E_star_GPa = contact_modulus_GPa(a.E_GPa, a.nu, b.E_GPa, b.nu);
    p.R_nm = R_nm;
    p.W_mJ_m2 = W_mJ_m2;
    p.length_nm = length_nm;
    check_range("R_nm", R_nm, 0.0, kMaxRadiusNm, true);
    check_range("W_mJ_m2", W_mJ_m2, 0.0, kMaxWorkOfAdhesion, false);
    return p;
}

void check_pair(Model m, const Pair &p)
{
    check_range("E_star_GPa", p.E_star_GPa, kMinModulusGPa, kMaxModulusGPa, false);
    check_range("R_nm", p.R_nm, 0.0, kMaxRadiusNm, true);
    check_range("W_mJ_m2", p.W_mJ_m2, 0.0, kMaxWorkOfAdhesion, false);
    if (m == Model::hertz && p.W_mJ_m2 != 0)
        refuse("W_mJ_m2", "0 for hertz (no adhesion: choose dmt or jkr)", p.W_mJ_m2);
    if (m == Model::line) check_range("length_nm", p.length_nm, 0.0, kMaxRadiusNm, true);
    const double fold = Branch(m, p).fold();
    if (fold > p.R_nm)
        refuse("R_nm", std::string("larger than the ") + model_name(m) + " pull-off contact radius " + show(fold) +
                           " nm (a neck wider than the body: no model holds)", p.R_nm);
}

double pull_off_nN(Model m, const Pair &p)
{
    check_pair(m, p);
    const double W = p.W_mJ_m2 * kMilliToNanoNewtonPerNm;
    switch (m) {
    case Model::hertz: return 0.0;
    case Model::dmt: return 2.0 * kPi * W * p.R_nm;
    case Model::jkr: return 1.5 * kPi * W * p.R_nm;
    case Model::line: return 1.5 * std::cbrt(kPi * p.E_star_GPa * W * W * p.R_nm / 2.0) * p.length_nm;
    }
    return 0;
}

Contact solve(Model m, const Pair &p, double load_nN)
{
    check_range("load_nN", load_nN, -kMaxLoadNn, kMaxLoadNn, false);
    Contact c;
    c.load_nN = load_nN;
    if (load_nN <= -pull_off_nN(m, p)) return c;   // at or below the pull-off: no contact
    const Branch b(m, p);
    if (b.force(p.R_nm) < load_nN)
        refuse("load_nN", std::string("at most ") + show(b.force(p.R_nm)) + " nN for " + model_name(m) + " with R " +
                              show(p.R_nm) + " nm (a contact wider than the body)", load_nN);
    // N(a) rises from its fold to R: bisect to the last representable step.
    double lo = b.fold(), hi = p.R_nm;
    for (int i = 0; i < 200 && hi - lo > 1e-15 * hi; ++i) {
        const double mid = 0.5 * (lo + hi);
        (b.force(mid) < load_nN ? lo : hi) = mid;
    }
    const double a = 0.5 * (lo + hi);
    c.in_contact = true;
    c.a_nm = a;
    c.delta_nm = b.delta(a);
    c.area_nm2 = m == Model::line ? 2.0 * a * p.length_nm : kPi * a * a;
    c.stiffness_nN_per_nm = std::max(0.0, b.stiffness(a));   // jkr, line: 0 at the fold, not -0 from rounding
    c.beyond_small_strain = a > kSmallStrain * p.R_nm;
    return c;
}

Tabor tabor(const Pair &p, double z0_nm)
{
    check_pair(Model::jkr, p);
    check_range("z0_nm", z0_nm, 0.0, 10.0, true);
    const double W = p.W_mJ_m2 * kMilliToNanoNewtonPerNm;
    Tabor t;
    t.mu = std::cbrt(p.R_nm * W * W / (p.E_star_GPa * p.E_star_GPa * z0_nm * z0_nm * z0_nm));
    t.apt = t.mu < 0.1 ? "dmt" : t.mu > 5.0 ? "jkr" : "maugis";
    return t;
}

double friction_nN(const Friction &f, const Contact &c, bool sliding)
{
    check_range("mu_static", f.mu_static, 0.0, 10.0, false);
    check_range("mu_kinetic", f.mu_kinetic, 0.0, 10.0, false);
    check_range("tau_MPa", f.tau_MPa, 0.0, 1e5, false);
    if (!c.in_contact) return 0.0;
    const double mu = sliding ? f.mu_kinetic : f.mu_static;
    return std::max(0.0, mu * c.load_nN + f.tau_MPa * kMPaToGPa * c.area_nm2);
}

double capillary_force_nN(double R_nm, const Capillary &c)
{
    check_range("R_nm", R_nm, 0.0, kMaxRadiusNm, true);
    check_range("RH", c.RH, 0.0, 1.0, false);
    check_range("theta_deg", c.theta_deg, 0.0, 180.0, false);
    if (c.theta_deg >= 180.0) refuse("theta_deg", "below 180", c.theta_deg);
    check_range("gap_nm", c.gap_nm, 0.0, 100.0, false);
    const double cos_t = std::cos(c.theta_deg * kPi / 180.0);
    if (c.RH <= 0.0 || c.theta_deg >= 90.0) return 0.0;   // no water, or water that does not wet: no meniscus
    const double full = 4.0 * kPi * R_nm * kWaterSurfaceTension_mN_m * kMilliToNanoNewtonPerNm * cos_t;
    if (c.RH >= 1.0 || c.gap_nm == 0.0) return full;   // r_K infinite, or no gap to bridge
    const double r_K = kWaterKelvinLength_nm / std::log(1.0 / c.RH);
    return full * std::max(0.0, 1.0 - c.gap_nm / (2.0 * r_K * cos_t));
}

}  // namespace afm::sim::contact
