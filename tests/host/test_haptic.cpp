// Unity tests of the operator's side of the force loop (host/haptic,
// hand_script): the stated stability bound against the loop itself (inside
// it the free stylus settles, outside it an oscillation grows unless the
// passivity controller clamps it), the bound's figures for a scene, the
// stroke that feel mode ends, the workspace's stop.
#include <unity.h>

#include "../scene_text.hpp"

#include <cmath>
#include <cstdio>
#include <deque>
#include <string>

#include "card_setup.hpp"
#include "hand_script.hpp"
#include "haptic_device.hpp"
#include "haptic_bound.hpp"

namespace {

constexpr double kT = 1e-3;   // one block


const char *kScene = R"(name: t
seed: 1
duration_s: 1
sample:
  substrate: glass
  field_nm: 5000
objects:
  particles:
    - {id: 1, x_nm: 0, y_nm: 0, radius_nm: 50}
operator:
  path_nm: [[0, -500], [0, 500], [-500, -500]]
)";

struct Run {
    double energy0, energy_end, peak_energy;
    long controller_blocks;
    double controller_J;
};

// The loop as the bench closes it, on a spring wall of stiffness K at the
// stylus: the force held over block k answers the stylus position at the
// end of block k - 3 (the pose of block k - 2, the piezo's block k - 1, the
// force measured then, held over block k). The hand has let go (the worst
// case: it would add damping); the stylus starts moving at v0.
Run free_stylus(double K, bool controller, double seconds = 20, double v0 = 0.05)
{
    afm::HapticSpec dev;
    afm::HandSpec hand;
    hand.stiffness_N_per_m = 0;
    hand.damping_Ns_per_m = 0;
    afm::HapticLoop loop(dev, hand, kT, {0, 0}, {v0, 0});   // thrown: the energy is the hand's, not the device's
    loop.set_controller(controller);
    std::deque<double> x_end(3, 0.0);
    auto energy = [&] {
        const double x = loop.position_m().x, v = loop.velocity_m_per_s().x;
        return 0.5 * hand.mass_kg * v * v + 0.5 * K * x * x;
    };
    Run r{energy(), 0, 0, 0, 0};
    const long blocks = static_cast<long>(seconds / kT);
    for (long k = 0; k < blocks; ++k) {
        const double f = -K * x_end.front();
        x_end.pop_front();
        loop.step({0, 0}, {f, 0});
        x_end.push_back(loop.position_m().x);
        r.peak_energy = std::max(r.peak_energy, energy());
    }
    r.energy_end = energy();
    r.controller_blocks = loop.controller_blocks();
    r.controller_J = loop.controller_energy_J();
    return r;
}

double bound_of_defaults()
{
    const afm::HapticSpec dev;
    return dev.damping_Ns_per_m / (kT * (0.5 + 2));
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_bound_figures_for_a_scene()
{
    const afm::Scene s = scene_from_text(std::string(kScene) + "  haptic: {force_gain_N_per_nN: 0.02}\n");
    const afm::HapticBound b = afm::haptic_bound(s, afm::CardSetup(s).config());
    // g k_c s from the scene's values: the lateral gain over the firmware's
    // estimate C = 3 h K_n / (2 l) is the stiffer of the two directions.
    const double C_nm_per_V = 3 * s.probe.tip_height_um * s.probe.deflection_nm_per_V / (2 * s.probe.lever_length_um);
    const double k_c = s.probe.lateral_nN_per_V / C_nm_per_V;
    const double scale = s.op.kappa * s.field_nm / 2 * 1e-9 / (s.op.haptic.half_range_mm * 1e-3);
    const double K_r = 0.02 * 1e9 * k_c * scale;
    TEST_ASSERT_DOUBLE_WITHIN(1e-3 * K_r, K_r, b.rendered_N_per_m);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, bound_of_defaults(), b.max_rendered_N_per_m);
    TEST_ASSERT_EQUAL(K_r < b.max_rendered_N_per_m, b.passive);
    // The largest gain that passes: just inside; 0.001 N/nN more is outside.
    const double g_max = b.max_gain_N_per_nN;
    TEST_ASSERT_TRUE(g_max * 1e9 * k_c * scale < b.max_rendered_N_per_m);
    TEST_ASSERT_TRUE((g_max + 0.001) * 1e9 * k_c * scale >= b.max_rendered_N_per_m * 0.999);
    std::printf("default scene: K_r %.1f N/m, bound %.1f N/m, largest gain %.3f N/nN\n", b.rendered_N_per_m, b.max_rendered_N_per_m, g_max);
}

void test_refusal_names_keys_and_the_largest_gain()
{
    std::string yaml = kScene;
    yaml += "  haptic: {force_gain_N_per_nN: 0.05}\n";
    const afm::Scene s = scene_from_text(yaml);
    auto refusal = [](const afm::Scene &x) { return afm::haptic_refusal(x, afm::CardSetup(x).config()); };
    const std::string why = refusal(s);
    TEST_ASSERT_TRUE(why.find("operator.haptic.force_gain_N_per_nN") == 0);
    TEST_ASSERT_TRUE(why.find("operator.haptic.damping_Ns_per_m 3") != std::string::npos);
    TEST_ASSERT_TRUE(why.find("the largest gain that passes is 0.023 N/nN") != std::string::npos);
    // passivity_check false: no refusal (the controller clamps instead).
    const afm::Scene s2 = scene_from_text(std::string(kScene) + "  haptic: {force_gain_N_per_nN: 0.05, passivity_check: false}\n");
    TEST_ASSERT_EQUAL_STRING("", refusal(s2).c_str());
    // Inside: none.
    TEST_ASSERT_EQUAL_STRING("", refusal(scene_from_text(kScene)).c_str());
    // The device's own stiffness limit.
    const afm::Scene s3 = scene_from_text(std::string(kScene) + "  haptic: {max_stiffness_N_per_m: 500, force_gain_N_per_nN: 0.02}\n");
    TEST_ASSERT_TRUE(refusal(s3).find("max_stiffness_N_per_m 500") != std::string::npos);
}

void test_auto_gain_is_four_fifths_of_the_largest()
{
    // Left out, the gain is 4/5 of the largest inside the bound, in whole
    // uN/pN: inside for any field (the scale grows with it).
    for (const char *field : {"2000", "5000", "20000"}) {
        std::string yaml = kScene;
        yaml.replace(yaml.find("5000"), 4, field);
        const afm::Scene s = scene_from_text(yaml);
        const afm::CardSetup card(s);
        const afm::HapticBound b = afm::haptic_bound(s, card.config());
        TEST_ASSERT_TRUE(b.passive && b.within_device);
        const double g = card.config().haptic_un_per_pn * 1e-3;
        TEST_ASSERT_TRUE(g <= 0.8 * (b.max_gain_N_per_nN + 0.001) + 1e-12);
        TEST_ASSERT_TRUE(g + 0.002 > 0.8 * b.max_gain_N_per_nN);
        TEST_ASSERT_EQUAL_STRING("", afm::haptic_refusal(s, card.config()).c_str());
    }
}

void test_inside_the_bound_the_free_stylus_settles()
{
    const double Kmax = bound_of_defaults();
    const Run r = free_stylus(0.9 * Kmax, false);
    std::printf("K = 0.9 K_max: energy %.3g -> %.3g J\n", r.energy0, r.energy_end);
    TEST_ASSERT_TRUE(r.energy_end < 0.01 * r.energy0);
    TEST_ASSERT_TRUE(r.peak_energy <= 1.0001 * r.energy0 + 1e-12);
    // The controller has nothing to do there.
    const Run c = free_stylus(0.9 * Kmax, true);
    TEST_ASSERT_EQUAL(0, c.controller_blocks);
}

void test_outside_the_bound_it_grows_unless_clamped()
{
    const double Kmax = bound_of_defaults();
    // The bound is close to where the loop turns unstable: 30 % beyond it an
    // oscillation grows (the test would pass with a bound far too lax).
    const Run r = free_stylus(1.3 * Kmax, false);
    std::printf("K = 1.3 K_max, no controller: energy %.3g -> %.3g J\n", r.energy0, r.energy_end);
    TEST_ASSERT_TRUE(r.energy_end > 100 * r.energy0);
    for (double k : {1.3, 3.0, 10.0}) {
        const Run c = free_stylus(k * Kmax, true);
        std::printf("K = %.1f K_max, controller: energy %.3g -> %.3g J, peak %.3g J, %ld blocks, %.3g J taken\n", k, c.energy0,
                    c.energy_end, c.peak_energy, c.controller_blocks, c.controller_J);
        TEST_ASSERT_TRUE(c.controller_blocks > 0);
        TEST_ASSERT_TRUE(c.energy_end < c.energy0);
        TEST_ASSERT_TRUE(c.peak_energy < 3 * c.energy0);
    }
}

void test_bound_is_safe_and_close()
{
    // Where the free stylus turns unstable, by bisection on K / K_max: not
    // below the bound (it is safe), and within 30 % of it (it is close).
    const double Kmax = bound_of_defaults();
    double lo = 0.5, hi = 2.0;
    for (int i = 0; i < 20; ++i) {
        const double mid = 0.5 * (lo + hi);
        const Run r = free_stylus(mid * Kmax, false, 20);
        (r.energy_end > r.energy0 ? hi : lo) = mid;
    }
    std::printf("the free stylus turns unstable at K = %.3f K_max\n", lo);
    TEST_ASSERT_TRUE(lo >= 1.0);
    TEST_ASSERT_TRUE(lo <= 1.3);
}

void test_controller_at_standstill_stays_finite()
{
    // A stylus at rest pushed by an active force: the controller's damping
    // at (near) zero speed is capped, the state stays finite.
    afm::HapticSpec dev;
    afm::HandSpec hand;
    afm::HapticLoop loop(dev, hand, kT, {0, 0});
    for (int k = 0; k < 2000; ++k) loop.step({0, 0}, {k % 2 ? 1.0 : -1.0, 0});
    TEST_ASSERT_TRUE(std::isfinite(loop.position_m().x) && std::isfinite(loop.velocity_m_per_s().x));
    TEST_ASSERT_TRUE(std::fabs(loop.position_m().x) < 0.01);
}

void test_workspace_stop()
{
    afm::HapticSpec dev;
    afm::HandSpec hand;
    afm::HapticLoop loop(dev, hand, kT, {0, 0});
    for (int k = 0; k < 2000; ++k) loop.step({1.0, 0}, {0, 0});   // aims a metre away
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, dev.half_range_mm * 1e-3, loop.position_m().x);
    TEST_ASSERT_TRUE(loop.edge_blocks() > 0);
}

void test_hand_follows_a_moving_aim_without_lag()
{
    // Velocity feed-forward: at constant speed the stylus keeps up, behind
    // only by what the device's damping takes, b v / K_h.
    afm::HapticSpec dev;
    afm::HandSpec hand;
    afm::HapticLoop loop(dev, hand, kT, {0, 0});
    const double v = 0.05;
    for (int k = 1; k <= 1000; ++k) loop.step({v * k * kT, 0}, {0, 0});
    TEST_ASSERT_DOUBLE_WITHIN(1e-5, v, loop.velocity_m_per_s().x);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, v * 1.0 - dev.damping_Ns_per_m * v / hand.stiffness_N_per_m, loop.position_m().x);
}

void test_feel_ends_the_stroke_script_does_not()
{
    const std::string feel = std::string(kScene) + "  mode: feel\n  feel_threshold_N: 0.02\n  speed_nm_per_s: 1000\n";
    afm::HandScript h(scene_from_text(feel)), s(scene_from_text(kScene));
    afm::Vec2 a, b;
    for (int k = 0; k < 300; ++k) a = h.advance(kT, {0, 0}), b = s.advance(kT, {0, 0});
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, -200, a.y);   // 300 ms at 1000 nm/s from -500
    // Contact: the force against the stroke (+y) is -y on the tip.
    a = h.advance(kT, {0, -0.03});
    b = s.advance(kT, {0, -0.03});
    TEST_ASSERT_EQUAL(1, static_cast<int>(h.contacts().size()));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, -200, h.contacts()[0].aim_nm.y);
    // The next stroke heads for (-500, -500) from where it stopped.
    TEST_ASSERT_TRUE(a.x < 0 && a.y < -200);
    TEST_ASSERT_TRUE(b.y > -200);   // the script goes on
    // Below the threshold nothing happens; one contact ends one stroke.
    for (int k = 0; k < 50; ++k) h.advance(kT, {0, 0.019});
    TEST_ASSERT_EQUAL(1, static_cast<int>(h.contacts().size()));
}

// ---- the stylus's third axis (operator.haptic.load_span_nN) ----

// free_stylus on z: the hand has let go, the stylus starts at z0 (below the
// centre, pressing), the device's z force answers the depth three blocks
// back through a spring of stiffness K (the load's spring, g span / range).
double free_stylus_z(double K, bool controller, double seconds = 20)
{
    // Energy at the end over the energy at the start (the spring's, about
    // its rest depth z_r; the stylus starts 5 mm off it, at rest).
    afm::HapticSpec dev;
    dev.load_span_nN = 20;
    afm::HandSpec hand;
    hand.stiffness_N_per_m = 0;
    hand.damping_Ns_per_m = 0;
    afm::HapticLoop loop(dev, hand, kT, {0, 0});
    loop.set_controller(controller);
    const double z_r = -0.02, z0 = z_r + 0.005;
    loop.place_z(z0);
    std::deque<double> z_end(3, z0);
    for (long k = 0; k < static_cast<long>(seconds / kT); ++k) {
        const double f = -K * (z_end.front() - z_r);
        z_end.pop_front();
        loop.step({0, 0}, {0, 0}, z0, f);   // the aim does not pull: the hand's spring is 0
        z_end.push_back(loop.z_m());
    }
    const double dz = loop.z_m() - z_r;
    return dz * dz / (0.005 * 0.005);   // the potential energy's ratio (the stylus's speed is 0 at its turns)
}

void test_z_axis_sets_the_load_and_feels_f_z()
{
    afm::HapticSpec dev;
    dev.load_span_nN = 20;
    afm::HandSpec hand;
    const double reach = dev.half_range_mm * 1e-3;
    afm::HapticLoop loop(dev, hand, kT, {0, 0});
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, loop.load_nN());   // at the centre: no load
    for (int k = 0; k < 3000; ++k) loop.step({0, 0}, {0, 0}, -0.5 * reach, 0);
    TEST_ASSERT_DOUBLE_WITHIN(0.01, 10.0, loop.load_nN());   // pressed half way: half the span
    // Felt: a constant F_z of 0.3 N up lifts the stylus by F / K_hand.
    for (int k = 0; k < 3000; ++k) loop.step({0, 0}, {0, 0}, -0.5 * reach, 0.3);
    const double lift_m = 0.3 / hand.stiffness_N_per_m;
    TEST_ASSERT_DOUBLE_WITHIN(0.01, 20.0 * (0.5 * reach - lift_m) / reach, loop.load_nN());
    // Lifted above the centre: no load, not a negative one; past the stop: the span.
    for (int k = 0; k < 3000; ++k) loop.step({0, 0}, {0, 0}, 0.3 * reach, 0);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, loop.load_nN());
    for (int k = 0; k < 3000; ++k) loop.step({0, 0}, {0, 0}, -2 * reach, 0);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 20.0, loop.load_nN());
    TEST_ASSERT_TRUE(loop.edge_blocks() > 0);
    // Without the axis z is not integrated, whatever the force.
    afm::HapticLoop flat(afm::HapticSpec{}, hand, kT, {0, 0});
    for (int k = 0; k < 100; ++k) flat.step({0, 0}, {0, 0}, -0.5 * reach, 1.0);
    TEST_ASSERT_DOUBLE_WITHIN(1e-15, 0.0, flat.z_m());
}

void test_z_axis_is_held_to_the_same_bound()
{
    const double Kmax = bound_of_defaults();
    const double in = free_stylus_z(0.9 * Kmax, false), out = free_stylus_z(1.3 * Kmax, false);
    const double clamped = free_stylus_z(1.3 * Kmax, true);
    std::printf("z axis: energy ratio at 0.9 K_max %.3g, at 1.3 K_max %.3g (with the controller %.3g)\n", in, out, clamped);
    TEST_ASSERT_TRUE(in < 0.01);
    TEST_ASSERT_TRUE(out > 100);
    TEST_ASSERT_TRUE(clamped < 1);
}

void test_z_axis_enters_the_bound_and_the_scene_rules()
{
    const afm::Scene s = scene_from_text(std::string(kScene) + "  load_nN: 5\n  haptic: {force_gain_N_per_nN: 0.02, load_span_nN: 20}\n");
    const afm::HapticBound b = afm::haptic_bound(s, afm::CardSetup(s).config());
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.02 * 20 / 0.08, b.rendered_z_N_per_m);   // g span / half range: 5 N/m
    // A span and gain that put z outside the bound: refused, the refusal names the z axis's key.
    const afm::Scene big = scene_from_text(std::string(kScene) + "  load_nN: 5\n  haptic: {force_gain_N_per_nN: 0.1, load_span_nN: 1000}\n");
    const afm::HapticBound bb = afm::haptic_bound(big, afm::CardSetup(big).config());
    std::printf("span 1000 nN, gain 0.1: K_z %.1f N/m against K_max %.1f\n", bb.rendered_z_N_per_m, bb.max_rendered_N_per_m);
    TEST_ASSERT_TRUE(bb.rendered_z_N_per_m > bb.max_rendered_N_per_m);
    TEST_ASSERT_FALSE(bb.passive);
    TEST_ASSERT_TRUE(afm::haptic_refusal(big, afm::CardSetup(big).config()).find("load_span_nN 1000") != std::string::npos);
    // The script asks for more than the stylus's stop gives: refused, naming both.
    bool refused = false;
    try {
        (void)scene_from_text(std::string(kScene) + "  load_nN: 30\n  haptic: {load_span_nN: 20}\n");
    } catch (const std::exception &e) {
        refused = std::string(e.what()).find("operator.haptic.load_span_nN") != std::string::npos;
    }
    TEST_ASSERT_TRUE(refused);
}

// ---- the step test: the stylus's lag behind the hand, and the bound ----

// The closed form of the free stylus pulled by the hand towards a step of
// size a (no rendered force): m x'' + c x' + K_h x = K_h a + B_h a' with
// c = B_h + b. The hand's damper pulls along with the aim's own motion, so
// the step gives the stylus v0 = B_h a / m at once; from x = 0 then,
// underdamped (zeta < 1 for the default hand), x / a = 1 - e^(-s t)
// (cos(w t) - (v0 / a - s) / w sin(w t)), s = c / 2m, w = sqrt(K/m - s^2).
// The time it first reaches 90 % of a.
double t90_closed_form(const afm::HandSpec &hand, double b)
{
    const double m = hand.mass_kg, K = hand.stiffness_N_per_m, c = hand.damping_Ns_per_m + b;
    const double sg = c / (2 * m), w2 = K / m - sg * sg, v0 = hand.damping_Ns_per_m / m;
    TEST_ASSERT_TRUE(w2 > 0);
    const double w = std::sqrt(w2);
    auto x = [&](double t) { return 1 - std::exp(-sg * t) * (std::cos(w * t) - (v0 - sg) / w * std::sin(w * t)); };
    double lo = 0, hi = 0;
    while (x(hi) < 0.9) hi += 1e-4;   // the first crossing, then bisected
    lo = hi - 1e-4;
    for (int i = 0; i < 40; ++i) (x(0.5 * (lo + hi)) < 0.9 ? lo : hi) = 0.5 * (lo + hi);
    return hi;
}

void test_step_lag_matches_the_closed_form_and_stays_bounded_against_a_wall()
{
    // A 10 mm step of the hand's aim (the pointer jumping): the stylus
    // follows with the lag of the hand's spring, damper and mass (what the
    // page draws as the dashed line from the target to the tip).
    afm::HapticSpec dev;
    afm::HandSpec hand;
    afm::HapticLoop loop(dev, hand, kT, {0, 0});
    const double a = 0.01;
    double t90 = -1;
    for (int k = 1; k <= 2000 && t90 < 0; ++k) {
        loop.step({a, 0}, {0, 0});
        if (loop.position_m().x >= 0.9 * a) t90 = k * kT;
    }
    const double want = t90_closed_form(hand, dev.damping_Ns_per_m);
    std::printf("step 10 mm: the stylus reaches 90 %% in %.1f ms (closed form %.1f ms; blocks of 1 ms)\n", t90 * 1e3, want * 1e3);
    TEST_ASSERT_TRUE(t90 > 0);
    TEST_ASSERT_DOUBLE_WITHIN(kT + 0.03 * want, want, t90);   // within a block and 3 %
    // The same step into a wall the card renders at 0.9 K_max behind the
    // loop's delay: the stylus stops at the balance of the hand's spring and
    // the wall, K_h a = (K_h + K_w) x, without a growing oscillation.
    const double Kw = 0.9 * bound_of_defaults();
    afm::HapticLoop wall(dev, hand, kT, {0, 0});
    std::deque<double> x_end(3, 0.0);
    double peak = 0;
    for (int k = 0; k < 5000; ++k) {
        const double f = x_end.front() > 0 ? -Kw * x_end.front() : 0.0;
        x_end.pop_front();
        wall.step({a, 0}, {f, 0});
        x_end.push_back(wall.position_m().x);
        peak = std::max(peak, wall.position_m().x);
    }
    const double rest = hand.stiffness_N_per_m * a / (hand.stiffness_N_per_m + Kw);
    std::printf("into a wall of %.0f N/m (0.9 K_max): rests at %.3f mm (balance %.3f mm), peak %.3f mm\n", Kw, wall.position_m().x * 1e3,
                rest * 1e3, peak * 1e3);
    TEST_ASSERT_DOUBLE_WITHIN(0.01 * rest, rest, wall.position_m().x);
    TEST_ASSERT_TRUE(peak < a);   // the wall holds it short of the aim all along
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_bound_figures_for_a_scene);
    RUN_TEST(test_z_axis_sets_the_load_and_feels_f_z);
    RUN_TEST(test_step_lag_matches_the_closed_form_and_stays_bounded_against_a_wall);
    RUN_TEST(test_z_axis_is_held_to_the_same_bound);
    RUN_TEST(test_z_axis_enters_the_bound_and_the_scene_rules);
    RUN_TEST(test_refusal_names_keys_and_the_largest_gain);
    RUN_TEST(test_auto_gain_is_four_fifths_of_the_largest);
    RUN_TEST(test_inside_the_bound_the_free_stylus_settles);
    RUN_TEST(test_outside_the_bound_it_grows_unless_clamped);
    RUN_TEST(test_bound_is_safe_and_close);
    RUN_TEST(test_controller_at_standstill_stays_finite);
    RUN_TEST(test_workspace_stop);
    RUN_TEST(test_hand_follows_a_moving_aim_without_lag);
    RUN_TEST(test_feel_ends_the_stroke_script_does_not);
    return UNITY_END();
}
