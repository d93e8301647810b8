// Unity tests of the contact models (sim_afm/contact_models.hpp) against
// their closed forms, each computed here independently of the library: the
// library solves each model's N(a) by bisection and measures the pull-off by
// retracting along it; the tests write a(N) and the pull-off in closed form.
// Tolerance 1 % (issue 47) unless a row says otherwise.
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "contact_models.hpp"
#include "process.hpp"

namespace c = afm::sim::contact;
using c::Control;
using c::Model;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTol = 0.01;

// E* 52.4 GPa: a silicon tip on glass (the table's), R 20 nm, W 90 mJ/m^2.
c::Pair tip_on_glass(double W_mJ_m2 = 90.0, double R_nm = 20.0)
{
    return c::make_pair(c::material("silicon"), c::material("glass"), R_nm, W_mJ_m2);
}

c::Pair pair(double E, double R, double W, double L = 0)
{
    c::Pair p;
    p.E_star_GPa = E;
    p.R_nm = R;
    p.W_mJ_m2 = W;
    p.length_nm = L;
    return p;
}

void near(double expected, double actual, double rel, int line, const char *what)
{
    char msg[160];
    std::snprintf(msg, sizeof msg, "line %d: %s: expected %.9g, got %.9g", line, what, expected, actual);
    TEST_ASSERT_TRUE_MESSAGE(std::isfinite(actual), msg);
    TEST_ASSERT_TRUE_MESSAGE(std::fabs(actual - expected) <= rel * std::fabs(expected), msg);
}

// The message of the InputError fn throws ("" if none).
template <class Fn> std::string refusal(Fn fn)
{
    try {
        fn();
    } catch (const afm::InputError &e) {
        return e.what();
    }
    return "";
}

bool has(const std::string &s, const char *part) { return s.find(part) != std::string::npos; }

double W_nN_per_nm(const c::Pair &p) { return p.W_mJ_m2 * 1e-3; }

}  // namespace

void setUp() {}
void tearDown() {}

void test_model_names_round_trip_and_an_unknown_name_is_refused()
{
    for (Model m : {Model::hertz, Model::dmt, Model::jkr, Model::line})
        TEST_ASSERT_TRUE(c::model_from_name(c::model_name(m)) == m);
    TEST_ASSERT_EQUAL_STRING("jkr", c::model_name(Model::jkr));
    const std::string e = refusal([] { c::model_from_name("mD"); });
    TEST_ASSERT_TRUE_MESSAGE(has(e, "'mD'") && has(e, "hertz, dmt, jkr or line"), e.c_str());
}

void test_contact_radius_by_load_matches_each_closed_form()
{
    const c::Pair p = tip_on_glass();
    const double E = p.E_star_GPa, R = p.R_nm, W = W_nN_per_nm(p);
    const c::Pair h = tip_on_glass(0.0);
    for (double N : {0.01, 0.5, 1.0, 5.0, 20.0, 100.0}) {
        near(std::cbrt(3 * N * R / (4 * E)), c::solve(Model::hertz, h, N).a_nm, kTol, __LINE__, "hertz a");
    }
    for (double N : {-8.0, -5.0, -1.0, 0.0, 1.0, 5.0, 20.0, 100.0}) {   // jkr pull-off 8.48 nN, dmt 11.3 nN
        const double s = 3 * kPi * W * R;
        near(std::cbrt(3 * R / (4 * E) * (N + s + std::sqrt(2 * s * N + s * s))), c::solve(Model::jkr, p, N).a_nm,
             kTol, __LINE__, "jkr a");
        near(std::cbrt(3 * R * (N + 2 * kPi * W * R) / (4 * E)), c::solve(Model::dmt, p, N).a_nm, kTol, __LINE__,
             "dmt a");
    }
}

void test_indentation_gives_back_the_load_by_each_force_indentation_law()
{
    // Hertz and DMT: N = 4/3 E* sqrt(R) delta^(3/2) (- 2 pi W R), from delta alone.
    const c::Pair p = tip_on_glass();
    const double E = p.E_star_GPa, R = p.R_nm, W = W_nN_per_nm(p);
    for (double N : {1.0, 10.0, 50.0}) {
        const double dh = c::solve(Model::hertz, tip_on_glass(0.0), N).delta_nm;
        near(N, 4.0 / 3.0 * E * std::sqrt(R) * std::pow(dh, 1.5), kTol, __LINE__, "hertz N(delta)");
        const double dd = c::solve(Model::dmt, p, N).delta_nm;
        near(N, 4.0 / 3.0 * E * std::sqrt(R) * std::pow(dd, 1.5) - 2 * kPi * W * R, kTol, __LINE__, "dmt N(delta)");
    }
}

void test_line_half_width_matches_johnson()
{
    const c::Pair p = pair(52.4, 50.0, 0.0, 1000.0);   // a 100 nm wire, 1 um of it on the flat, no adhesion
    for (double N : {0.1, 1.0, 10.0, 100.0}) {
        const double Nl = N / p.length_nm;
        const c::Contact k = c::solve(Model::line, p, N);
        near(std::sqrt(4 * Nl * p.R_nm / (kPi * p.E_star_GPa)), k.a_nm, kTol, __LINE__, "line b");
        near(2 * k.a_nm * p.length_nm, k.area_nm2, 1e-12, __LINE__, "line area 2 b L");
    }
}

void test_stiffness_matches_the_slope_of_load_against_indentation()
{
    // dN/d(delta) from two solves 0.1 % apart in load, against the model's own.
    const c::Pair p = tip_on_glass();
    const c::Pair line = pair(52.4, 50.0, 90.0, 1000.0);
    struct Row { Model m; c::Pair p; double N; int line; };
    const Row rows[] = {{Model::hertz, tip_on_glass(0.0), 5.0, __LINE__}, {Model::dmt, p, 5.0, __LINE__},
                        {Model::jkr, p, 5.0, __LINE__},   {Model::jkr, p, -6.0, __LINE__},
                        {Model::line, line, 50.0, __LINE__}, {Model::line, pair(52.4, 50.0, 0.0, 1000.0), 50.0, __LINE__}};
    for (const Row &r : rows) {
        const double dN = 1e-3 * std::fabs(r.N);
        const c::Contact lo = c::solve(r.m, r.p, r.N - dN), hi = c::solve(r.m, r.p, r.N + dN);
        const double slope = 2 * dN / (hi.delta_nm - lo.delta_nm);
        near(slope, c::solve(r.m, r.p, r.N).stiffness_nN_per_nm, kTol, r.line, c::model_name(r.m));
    }
}

void test_jkr_pull_off_measured_under_load_control_is_1_5_pi_W_R()
{
    for (double R : {5.0, 20.0, 500.0}) {
        const c::Pair p = tip_on_glass(90.0, R);
        const double closed = 1.5 * kPi * W_nN_per_nm(p) * R;
        const c::Retraction r = c::retract(Model::jkr, p, 10.0, Control::load);
        near(-closed, r.min_force_nN, kTol, __LINE__, "jkr pull-off, load control");
        near(-closed, r.jump_force_nN, kTol, __LINE__, "jkr jump, load control");
        // the neck at separation: a_c^3 = 9 pi W R^2 / (8 E*)
        near(std::cbrt(9 * kPi * W_nN_per_nm(p) * R * R / (8 * p.E_star_GPa)), r.jump_a_nm, kTol, __LINE__, "a_c");
        near(closed, c::pull_off_nN(Model::jkr, p), 1e-12, __LINE__, "pull_off_nN");
        TEST_ASSERT_TRUE(r.steps > 100);   // measured over many steps, not in one
    }
}

void test_jkr_under_displacement_control_passes_1_5_and_jumps_at_5_6_pi_W_R()
{
    const c::Pair p = tip_on_glass();
    const double piWR = kPi * W_nN_per_nm(p) * p.R_nm;
    const c::Retraction r = c::retract(Model::jkr, p, 10.0, Control::displacement);
    near(-1.5 * piWR, r.min_force_nN, kTol, __LINE__, "least force, displacement control");
    near(-5.0 / 6.0 * piWR, r.jump_force_nN, kTol, __LINE__, "jump force, displacement control");
    near(std::cbrt(kPi * W_nN_per_nm(p) * p.R_nm * p.R_nm / (8 * p.E_star_GPa)), r.jump_a_nm, kTol, __LINE__, "a_d");
}

void test_jkr_on_a_spring_jumps_between_the_two_limits_stiffer_nearer_5_6()
{
    const c::Pair p = tip_on_glass();
    const double piWR = kPi * W_nN_per_nm(p) * p.R_nm;
    double last = -1.5 * piWR;
    for (double k : {0.1, 10.0, 100.0, 1000.0}) {   // nN/nm = N/m: an AFM lever to a stiff one
        const c::Retraction r = c::retract(Model::jkr, p, 10.0, Control::spring, k);
        near(-1.5 * piWR, r.min_force_nN, kTol, __LINE__, "least force on a spring");
        TEST_ASSERT_TRUE(r.jump_force_nN >= last - 1e-9);
        TEST_ASSERT_TRUE(r.jump_force_nN <= -5.0 / 6.0 * piWR * (1 - kTol));
        last = r.jump_force_nN;
    }
}

void test_dmt_and_hertz_pull_off_measured()
{
    const c::Pair p = tip_on_glass();
    const double closed = 2 * kPi * W_nN_per_nm(p) * p.R_nm;
    for (Control ctl : {Control::load, Control::displacement}) {
        const c::Retraction r = c::retract(Model::dmt, p, 10.0, ctl);
        near(-closed, r.min_force_nN, kTol, __LINE__, "dmt pull-off");
        TEST_ASSERT_TRUE(r.jump_a_nm < 1e-3 * p.R_nm);   // DMT separates at a point
    }
    const c::Retraction h = c::retract(Model::hertz, tip_on_glass(0.0), 10.0, Control::load);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.0, h.min_force_nN);
}

void test_line_pull_off_measured_matches_plane_strain_jkr()
{
    // per unit length: 1.5 (pi E* W^2 R / 2)^(1/3)
    const c::Pair p = pair(52.4, 50.0, 90.0, 1000.0);
    const double W = W_nN_per_nm(p);
    const double closed = 1.5 * std::cbrt(kPi * p.E_star_GPa * W * W * p.R_nm / 2) * p.length_nm;
    const c::Retraction r = c::retract(Model::line, p, 10.0, Control::load);
    near(-closed, r.min_force_nN, kTol, __LINE__, "line pull-off");
    near(closed, c::pull_off_nN(Model::line, p), 1e-12, __LINE__, "line pull_off_nN");
    const std::string e = refusal([&] { c::retract(Model::line, p, 10.0, Control::displacement); });
    TEST_ASSERT_TRUE_MESSAGE(has(e, "load control"), e.c_str());
}

void test_jkr_with_no_adhesion_is_hertz()
{
    const c::Pair p = tip_on_glass(0.0);
    for (double N : {0.1, 3.0, 70.0}) {
        const c::Contact j = c::solve(Model::jkr, p, N), h = c::solve(Model::hertz, p, N);
        near(h.a_nm, j.a_nm, 1e-9, __LINE__, "a");
        near(h.delta_nm, j.delta_nm, 1e-9, __LINE__, "delta");
        near(h.stiffness_nN_per_nm, j.stiffness_nN_per_nm, 1e-9, __LINE__, "stiffness");
    }
    TEST_ASSERT_EQUAL_DOUBLE(0.0, c::pull_off_nN(Model::jkr, p));
    TEST_ASSERT_FALSE(c::solve(Model::jkr, p, 0.0).in_contact);
}

void test_a_load_at_or_below_the_pull_off_is_no_contact_not_nan()
{
    const c::Pair p = tip_on_glass();
    const c::Pair line = pair(52.4, 50.0, 90.0, 1000.0);
    struct Row { Model m; c::Pair p; };
    const Row rows[] = {{Model::hertz, tip_on_glass(0.0)}, {Model::dmt, p}, {Model::jkr, p}, {Model::line, line}};
    for (const Row &r : rows) {
        const double off = c::pull_off_nN(r.m, r.p);
        for (double N : {-off, -off - 1e-9, -2 * off - 1, -1e12}) {
            const c::Contact k = c::solve(r.m, r.p, N);
            TEST_ASSERT_FALSE_MESSAGE(k.in_contact, c::model_name(r.m));
            TEST_ASSERT_EQUAL_DOUBLE(0.0, k.a_nm);
            TEST_ASSERT_EQUAL_DOUBLE(0.0, k.delta_nm);
            TEST_ASSERT_EQUAL_DOUBLE(0.0, k.area_nm2);
            TEST_ASSERT_EQUAL_DOUBLE(N, k.load_nN);
        }
        const c::Contact just = c::solve(r.m, r.p, -off + 1e-6 * (off + 1));
        TEST_ASSERT_TRUE_MESSAGE(just.in_contact && std::isfinite(just.a_nm) && just.stiffness_nN_per_nm >= 0,
                                 c::model_name(r.m));
    }
}

void test_no_radius_no_modulus_and_bad_numbers_are_refused_naming_the_field()
{
    const c::Material &si = c::material("silicon");
    struct Row { const char *field; std::string e; };
    const Row rows[] = {
        {"R_nm", refusal([&] { c::make_pair(si, si, 0.0, 50.0); })},
        {"R_nm", refusal([&] { c::solve(Model::jkr, pair(50, -1, 50), 1.0); })},
        {"E_star_GPa", refusal([&] { c::solve(Model::jkr, pair(0, 20, 50), 1.0); })},
        {"E1_GPa", refusal([] { c::contact_modulus_GPa(0.0, 0.3, 70, 0.2); })},
        {"nu2", refusal([] { c::contact_modulus_GPa(70, 0.3, 70, 0.7); })},
        {"W_mJ_m2", refusal([&] { c::solve(Model::dmt, pair(50, 20, -1), 1.0); })},
        {"W_mJ_m2", refusal([&] { c::solve(Model::hertz, pair(50, 20, 50), 1.0); })},
        {"length_nm", refusal([&] { c::solve(Model::line, pair(50, 20, 50, 0), 1.0); })},
        {"load_nN", refusal([&] { c::solve(Model::jkr, pair(50, 20, 50), std::nan("")); })},
        {"load_nN", refusal([&] { c::solve(Model::jkr, pair(50, 20, 50), 1e300); })},
        {"R_nm", refusal([&] { c::solve(Model::jkr, pair(1e-6, 1, 1000), 1.0); })},   // the neck wider than the sphere
        {"spring_nN_per_nm", refusal([&] { c::retract(Model::jkr, pair(50, 20, 50), 1.0, Control::spring, 0); })},
        {"start_load_nN", refusal([&] { c::retract(Model::jkr, pair(50, 20, 50), -100.0, Control::load); })},
        {"unknown material 'unobtainium'", refusal([] { c::material("unobtainium"); })},
    };
    for (const Row &r : rows) {
        TEST_ASSERT_TRUE_MESSAGE(has(r.e, r.field), (std::string(r.field) + ": '" + r.e + "'").c_str());
        TEST_ASSERT_TRUE_MESSAGE(has(r.e, "contact: ") && r.e.find('\n') == std::string::npos, r.e.c_str());
    }
}

void test_huge_loads_stay_finite_or_are_refused_as_too_wide()
{
    // a 1 mm sphere under 1 kN: finite, flagged beyond small strain
    const c::Pair big = tip_on_glass(90.0, 1e6);
    const c::Contact k = c::solve(Model::jkr, big, 1e12);
    TEST_ASSERT_TRUE(k.in_contact && std::isfinite(k.a_nm) && std::isfinite(k.delta_nm) &&
                     std::isfinite(k.stiffness_nN_per_nm) && std::isfinite(k.area_nm2));
    TEST_ASSERT_TRUE(k.beyond_small_strain);
    near(std::cbrt(3 * 1e12 * 1e6 / (4 * big.E_star_GPa)), k.a_nm, kTol, __LINE__, "huge load a ~ hertz");
    // the same load on the 20 nm tip would make a contact wider than the tip
    const std::string e = refusal([] { c::solve(Model::dmt, tip_on_glass(), 1e12); });
    TEST_ASSERT_TRUE_MESSAGE(has(e, "load_nN") && has(e, "wider than the body"), e.c_str());
    TEST_ASSERT_TRUE(c::solve(Model::jkr, tip_on_glass(), 1.0).beyond_small_strain);   // a 20 nm tip: a = 2.2 nm
    TEST_ASSERT_FALSE(c::solve(Model::jkr, tip_on_glass(90.0, 200.0), 1.0).beyond_small_strain);   // 200 nm: a = 10 nm
}

void test_tabor_parameter_scales_as_the_cube_root_and_names_the_model()
{
    const c::Pair p = tip_on_glass();
    const c::Tabor t = c::tabor(p);
    const double W = W_nN_per_nm(p), E = p.E_star_GPa;
    near(std::pow(p.R_nm * W * W / (E * E * 0.027), 1.0 / 3.0), t.mu, 1e-12, __LINE__, "mu_T");
    near(2 * t.mu, c::tabor(tip_on_glass(90.0, 8 * p.R_nm)).mu, 1e-12, __LINE__, "mu_T(8R) = 2 mu_T(R)");
    TEST_ASSERT_EQUAL_STRING("maugis", t.apt);   // a sharp silicon tip on glass: between the limits
    TEST_ASSERT_EQUAL_STRING("dmt", c::tabor(pair(300, 5, 20)).apt);        // stiff, small, weak
    TEST_ASSERT_EQUAL_STRING("jkr", c::tabor(pair(0.01, 5000, 100)).apt);   // soft, large, sticky
}

void test_friction_by_load_is_mu_N_plus_tau_times_the_model_area()
{
    const c::Pair p = tip_on_glass();
    const double E = p.E_star_GPa, R = p.R_nm, W = W_nN_per_nm(p);
    const c::Friction f{0.3, 0.2, 100.0};   // tau 100 MPa = 0.1 nN/nm^2
    for (double N : {-5.0, 0.0, 2.0, 10.0, 40.0}) {
        const double s = 3 * kPi * W * R;
        const double a = std::cbrt(3 * R / (4 * E) * (N + s + std::sqrt(2 * s * N + s * s)));
        const double area_term = 0.1 * kPi * a * a;
        const c::Contact k = c::solve(Model::jkr, p, N);
        near(std::max(0.0, 0.3 * N + area_term), c::friction_nN(f, k, false), kTol, __LINE__, "static");
        near(std::max(0.0, 0.2 * N + area_term), c::friction_nN(f, k, true), kTol, __LINE__, "kinetic");
    }
    // the area grows with the load: friction is not proportional to it
    const double f1 = c::friction_nN(f, c::solve(Model::jkr, p, 1.0), true);
    const double f10 = c::friction_nN(f, c::solve(Model::jkr, p, 10.0), true);
    TEST_ASSERT_TRUE(f10 > f1 && f10 < 10 * f1);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, c::friction_nN(f, c::solve(Model::jkr, p, -20.0), true));
}

void test_capillary_meniscus_full_at_contact_limited_by_the_kelvin_radius()
{
    const double full = 4 * kPi * 20.0 * 0.0728;   // 4 pi R gamma, theta 0: 18.3 nN
    near(full, c::capillary_force_nN(20.0, {0.5, 0.0, 0.0}), 1e-12, __LINE__, "D = 0");
    near(full * std::cos(kPi / 3), c::capillary_force_nN(20.0, {1.0, 60.0, 0.3}), 1e-12, __LINE__, "RH 1");
    TEST_ASSERT_EQUAL_DOUBLE(0.0, c::capillary_force_nN(20.0, {0.0, 0.0, 0.3}));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, c::capillary_force_nN(20.0, {0.9, 95.0, 0.3}));
    // D 0.3 nm: 2 r_K = 0.3 nm at RH = exp(-2 * 0.538 / 0.3) = 2.8 %; below it no meniscus
    TEST_ASSERT_EQUAL_DOUBLE(0.0, c::capillary_force_nN(20.0, {0.02, 0.0, 0.3}));
    double last = 0;
    for (double RH : {0.05, 0.2, 0.4, 0.6, 0.8, 0.95}) {
        const double F = c::capillary_force_nN(20.0, {RH, 0.0, 0.3});
        TEST_ASSERT_TRUE(F > last && F < full);
        last = F;
    }
    const std::string e = refusal([] { c::capillary_force_nN(20.0, {1.5, 0.0, 0.3}); });
    TEST_ASSERT_TRUE_MESSAGE(has(e, "RH"), e.c_str());
}

void test_material_table_defaults_and_work_of_adhesion()
{
    const c::Material &si = c::material("silicon");
    TEST_ASSERT_EQUAL_DOUBLE(169.0, si.E_GPa);
    TEST_ASSERT_EQUAL_DOUBLE(0.27, si.nu);
    for (const c::Material &m : c::materials()) {
        TEST_ASSERT_TRUE_MESSAGE(m.E_GPa > 0 && m.nu >= 0 && m.nu < 0.5 && m.surface_energy_mJ_m2 > 0, m.name);
        TEST_ASSERT_EQUAL_STRING(m.name, c::material(m.name).name);
    }
    for (const char *name : {"silicon_nitride", "glass", "silica", "gold", "silver", "polystyrene", "polycarbonate"})
        TEST_ASSERT_EQUAL_STRING(name, c::material(name).name);
    const c::Material &ps = c::material("polystyrene");
    near(2 * std::sqrt(45.0 * 40.7), c::work_of_adhesion_mJ_m2(si, ps), 1e-12, __LINE__, "W = 2 sqrt(g1 g2)");
    near(c::work_of_adhesion_mJ_m2(ps, si), c::work_of_adhesion_mJ_m2(si, ps), 1e-15, __LINE__, "symmetric");
    // E*: the series of the two compliances; a flat's radius is the sphere's
    near(1 / ((1 - 0.27 * 0.27) / 169 + (1 - 0.22 * 0.22) / 70), tip_on_glass().E_star_GPa, 1e-12, __LINE__, "E*");
    near(20.0, c::effective_radius_nm(20.0, INFINITY), 1e-15, __LINE__, "sphere on flat");
    near(10.0, c::effective_radius_nm(20.0, 20.0), 1e-15, __LINE__, "two equal spheres");
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_model_names_round_trip_and_an_unknown_name_is_refused);
    RUN_TEST(test_contact_radius_by_load_matches_each_closed_form);
    RUN_TEST(test_indentation_gives_back_the_load_by_each_force_indentation_law);
    RUN_TEST(test_line_half_width_matches_johnson);
    RUN_TEST(test_stiffness_matches_the_slope_of_load_against_indentation);
    RUN_TEST(test_jkr_pull_off_measured_under_load_control_is_1_5_pi_W_R);
    RUN_TEST(test_jkr_under_displacement_control_passes_1_5_and_jumps_at_5_6_pi_W_R);
    RUN_TEST(test_jkr_on_a_spring_jumps_between_the_two_limits_stiffer_nearer_5_6);
    RUN_TEST(test_dmt_and_hertz_pull_off_measured);
    RUN_TEST(test_line_pull_off_measured_matches_plane_strain_jkr);
    RUN_TEST(test_jkr_with_no_adhesion_is_hertz);
    RUN_TEST(test_a_load_at_or_below_the_pull_off_is_no_contact_not_nan);
    RUN_TEST(test_no_radius_no_modulus_and_bad_numbers_are_refused_naming_the_field);
    RUN_TEST(test_huge_loads_stay_finite_or_are_refused_as_too_wide);
    RUN_TEST(test_tabor_parameter_scales_as_the_cube_root_and_names_the_model);
    RUN_TEST(test_friction_by_load_is_mu_N_plus_tau_times_the_model_area);
    RUN_TEST(test_capillary_meniscus_full_at_contact_limited_by_the_kelvin_radius);
    RUN_TEST(test_material_table_defaults_and_work_of_adhesion);
    return UNITY_END();
}
