// Unity tests of the simulated AFM (sim_afm/) against closed forms and the
// effect registry. Tolerances are stated per test, with their reason.
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <unistd.h>
#include <string>
#include <vector>

#include "scene.hpp"
#include "../scene_text.hpp"
#include "grid.hpp"
#include "world.hpp"

using afm::sim::World;

namespace {

const char *kBase = R"(name: unit
seed: 3
duration_s: 1
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [EFFECTS]
sample:
  substrate: glass
  field_nm: 2000
  tip_substrate: {mu: 0.1, adhesion_nN: 1.0}
  particle_substrate: {mu: 0.3, adhesion_nN: 3.0}
  drift_nm_per_min: [60, 0]
objects:
  particles:
    - {id: 1, x_nm: 0, y_nm: 0, radius_nm: 50}
operator:
  load_nN: 5
  path_nm: [[0, -300]]
)";

afm::Scene scene_with(const std::string &effects) { return scene_from_text(with(kBase, "EFFECTS", effects)); }

}  // namespace

void setUp() {}
void tearDown() {}

void test_particle_scene_builds_no_wire_drift_or_lithography_model()
{
    const afm::Scene s = scene_with("bending_offset");
    World w(s);
    const auto m = w.models_built();
    TEST_ASSERT_TRUE(has(m, "particles"));
    TEST_ASSERT_TRUE(has(m, "mechanics:compliant_lever"));
    for (const auto &name : m) {
        TEST_ASSERT_TRUE_MESSAGE(name.find("wire") == std::string::npos, name.c_str());
        TEST_ASSERT_TRUE_MESSAGE(name.find("drift") == std::string::npos, name.c_str());
        TEST_ASSERT_TRUE_MESSAGE(name.find("litho") == std::string::npos, name.c_str());
        TEST_ASSERT_TRUE_MESSAGE(name.find("noise") == std::string::npos, name.c_str());
        TEST_ASSERT_TRUE_MESSAGE(name.find("rough") == std::string::npos, name.c_str());
    }
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(w.wires().size()));   // no wire in the scene: no wire model
    for (int i = 0; i < 1000; ++i) w.step();
    TEST_ASSERT_EQUAL_DOUBLE(0.0, w.drift().norm());   // no drift model, no drift
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(w.trenches().size()));
}

void test_drift_listed_runs_and_moves_the_sample()
{
    const afm::Scene s = scene_with("thermal_drift");
    World w(s);
    TEST_ASSERT_TRUE(has(w.models_built(), "thermal_drift"));
    for (int i = 0; i < 20000; ++i) w.step();   // 1 s at 60 nm/min
    // Pure linear drift (no random walk in this scene): 1 nm, to rounding.
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 1.0, w.drift().x());
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 1.0, w.particle_position(0).x());
    bool timed = false;
    for (const auto &c : w.clocks())
        if (c.name == "thermal_drift") timed = c.seconds > 0;
    TEST_ASSERT_TRUE_MESSAGE(timed, "run.json must list thermal_drift with its time");
}

void test_clocks_time_one_sample_in_sixteen()
{
    const afm::Scene s = scene_with("thermal_drift");
    World w(s);
    for (const auto &c : w.clocks())
        if (c.name != "imaging" && c.name != "imaging+tip_convolution")
            TEST_ASSERT_EQUAL_DOUBLE_MESSAGE(0.0, c.seconds, "no sample stepped: no per-sample time");
    const int n = 16000;
    for (int i = 0; i < n; ++i) w.step();
    TEST_ASSERT_EQUAL_INT64(n, w.samples_stepped());
    // 1 in kClockEvery at random: 1000 expected, binomial sd about 31
    TEST_ASSERT_INT64_WITHIN(200, n / World::kClockEvery, w.samples_timed());
    // and not in a pattern that follows the block: every phase of 20 timed
    World v(s);
    std::vector<int> phases(20, 0);
    for (int i = 0; i < 4000; ++i) {
        const int64_t before = v.samples_timed();
        v.step();
        if (v.samples_timed() > before) ++phases[static_cast<std::size_t>(i % 20)];
    }
    for (int p : phases) TEST_ASSERT_GREATER_THAN_INT(0, p);
    for (const auto &c : w.clocks())
        if (c.name.rfind("mechanics", 0) == 0 || c.name == "thermal_drift") TEST_ASSERT_TRUE(c.seconds > 0);
}

void test_force_along_the_lever_reads_as_normal_load()
{
    // Section 1: k_n K_n S_n = F_z + (2h/l) F_x for the beam (rel. 1e-12: same
    // beam algebra, different route).
    const afm::Scene s = scene_with("bending_offset");
    const afm::sim::Lever lv(s.probe);
    const double h = lv.h, l = lv.l, knKn = lv.spring * lv.deflection;
    const double cases[][2] = {{0, 5}, {1, 5}, {-2, 0}, {3.5, -1}, {10, 10}};
    for (const auto &c : cases) {
        const double fx = c[0], fz = c[1];
        const double expected = (fz + 2 * h / l * fx) / knKn;
        TEST_ASSERT_DOUBLE_WITHIN(1e-12 * (1 + std::fabs(expected)), expected, lv.sn_volts(fx, fz));
    }
    // Lateral: S_l = F_y / (k_theta K_l / h).
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 1.0 / s.probe.lateral_nN_per_V, lv.sl_volts(1.0));
}

void test_apex_moves_forward_with_upward_bending()
{
    // The tip hangs h below the lever's end and turns with it: an upward bend
    // (S_n > 0) swings the apex towards the free end (+x in frame C), by
    // C_n S_n with C_n = 3 h K_n / (2 l) (sections 3, 4).
    const afm::Scene s = scene_with("bending_offset");
    const afm::sim::Lever lv(s.probe);
    const double fz = 5.0;
    const Eigen::Vector2d off = lv.apex_offset(Eigen::Vector2d::Zero(), fz);
    const double cn = 3 * lv.h * lv.deflection / (2 * lv.l);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, cn * lv.sn_volts(0, fz), off.x());
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, off.y());
}

void test_imaged_sphere_width_matches_tip_dilation_closed_form()
{
    // A sphere R under a tip (apex r_t, cone gamma) images as a bump whose
    // foot is at rho_0 = (R + r_t + (R - r_t) sin g) / cos g and whose top is
    // 2R. The image is the dilation over a lattice (dilation.hpp: the
    // display's 7.8 nm pixels split in two, h = 3.9 nm), bilinear between
    // its nodes: the foot lies within a step h of rho_0 (bisection to 1e-6
    // nm), the top, on a node, at 2R (test_dilation.cpp holds every node to
    // the closed form).
    const afm::Scene s = scene_with("tip_convolution");
    World w(s);
    const double R = 50, rt = s.probe.tip_radius_nm, g = s.probe.tip_half_angle_deg * M_PI / 180.0;
    const double rho0 = (R + rt + (R - rt) * std::sin(g)) / std::cos(g), h = 0.5 * s.field_nm / s.out.image_px;
    double lo = R, hi = 4 * R;
    while (hi - lo > 1e-6) {
        const double mid = 0.5 * (lo + hi);
        (w.image_height(mid, 0) > 1e-9 ? lo : hi) = mid;
    }
    std::printf("imaged foot radius %.6f nm, closed form %.6f nm, lattice step %.3f nm\n", lo, rho0, h);
    TEST_ASSERT_DOUBLE_WITHIN(h, rho0, lo);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 2 * R, w.image_height(0, 0));
    // Without tip convolution the image is the true topography: foot at R.
    World bare(scene_with("bending_offset"));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, bare.image_height(R + 1e-6, 0));
    TEST_ASSERT_TRUE(bare.image_height(R - 1e-3, 0) > 0);
}

void test_thermal_noise_level_is_kT_over_k()
{
    // <delta^2> = kT / k_n: the rms of K_n S_n over 2e5 samples of a lever
    // under constant load; the standard error of an rms from N samples is
    // 1/sqrt(2N) = 0.16%, so 1% tolerance.
    const afm::Scene s = scene_with("photodiode_noise");
    World w(s);
    const int n = 200000;
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
        const double v = w.step().sn_v;
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / n;
    const double rms_nm = std::sqrt(sum2 / n - mean * mean) * s.probe.deflection_nm_per_V;
    const double kT = 1.380649e-5 * s.temperature_K;   // nN nm
    const double expected = std::sqrt(kT / s.probe.spring_N_per_m);
    std::printf("deflection noise %.5f nm rms, sqrt(kT/k) %.5f nm\n", rms_nm, expected);
    TEST_ASSERT_DOUBLE_WITHIN(0.01 * expected, expected, rms_nm);
}

void test_pushed_particle_slides_at_its_threshold_in_contact_ahead()
{
    // Push across the lever (+y) through the particle's centre: once it
    // slides, the lateral force on the tip is tip friction + F_th (section 5)
    // and the particle sits r_t + r_p ahead: the contact is closed exactly
    // (physics.md 5.1; the penalty's give F_th / k_c is gone).
    const afm::Scene s = scene_with("bending_offset, adhesion");
    World w(s);
    // Start with the apex (not the piezo) on the line x = 0.
    const double cn_off = w.lever().normal_offset(s.op.load_nN).x();
    w.command(Eigen::Vector2d(-cn_off, -300), s.op.load_nN, true);
    for (int i = 0; i < 2000; ++i) w.step();
    w.command(Eigen::Vector2d(-cn_off, 100), s.op.load_nN, true);
    for (int i = 0; i < 20000; ++i) w.step();     // 20 um/s scanner limit: 20 ms per 400 nm, then rest
    const double fth = s.particle_substrate.mu * s.particle_substrate.adhesion_nN;
    const double friction = s.tip_substrate.mu * (s.op.load_nN + s.tip_substrate.adhesion_nN);
    const double reach = s.probe.tip_radius_nm + 50;
    const Eigen::Vector2d p = w.particle_position(0);
    std::printf("particle at (%.4f, %.4f), apex at (%.4f, %.4f), force (%.4f, %.4f) nN\n", p.x(), p.y(),
                w.apex().x(), w.apex().y(), w.tip_force().x(), w.tip_force().y());
    TEST_ASSERT_DOUBLE_WITHIN(0.05, reach, p.y() - w.apex().y());
    TEST_ASSERT_DOUBLE_WITHIN(0.05, 0.0, p.x());
    // At rest after the push the tip stays loaded by the particle (static):
    // |F| <= friction + F_th.
    TEST_ASSERT_TRUE(w.tip_force().head<2>().norm() <= friction + fth + 1e-6);
}

void test_same_seed_same_trajectory()
{
    const afm::Scene s = scene_with("bending_offset, photodiode_noise, thermal_drift");
    World a(s), b(s);
    a.command(Eigen::Vector2d(0, 100), 5, true);
    b.command(Eigen::Vector2d(0, 100), 5, true);
    for (int i = 0; i < 5000; ++i) {
        const auto x = a.step(), y = b.step();
        TEST_ASSERT_EQUAL_DOUBLE(x.sn_v, y.sn_v);
        TEST_ASSERT_EQUAL_DOUBLE(x.sl_v, y.sl_v);
    }
    TEST_ASSERT_EQUAL_DOUBLE(a.particle_position(0).y(), b.particle_position(0).y());
}

void test_landmark_pillar_images_flat_top_and_tip_limited_edge()
{
    // A 500 nm pillar, 200 nm high: its top images at 200 nm; beside it the
    // tip's flank meets the top edge, so at distance d the apex stands at
    // 200 - t(d) with t the tip's profile (spherical apex r_t, cone gamma).
    const std::string text = with(with(kBase, "EFFECTS", "tip_convolution"), "objects:\n  particles:\n    - {id: 1, x_nm: 0, y_nm: 0, radius_nm: 50}",
                                  "objects:\n  landmarks:\n    - {id: 9, x_nm: 400, y_nm: 400, side_nm: 500, height_nm: 200}");
    // The image: the dilation over a lattice of 3.9 nm steps (the display's
    // pixels split in two), bilinear between its nodes, so the edge stands
    // within a step of its place: within a step's height on the flank,
    // cot(g) h, of the closed form beside it.
    World w(scene_from_text(text));
    const double rt = 10, g = 20 * M_PI / 180, d = 30;   // on the cone part: d > r_t cos g
    const double step = 0.5 * 2000.0 / 256 / std::tan(g);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 200.0, w.image_height(400, 400));
    TEST_ASSERT_DOUBLE_WITHIN(step, 200.0, w.image_height(649, 400));
    const double t = rt - rt * std::sin(g) + (d - rt * std::cos(g)) / std::tan(g);
    TEST_ASSERT_DOUBLE_WITHIN(step, 200.0 - t, w.image_height(650 + d, 400));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, w.image_height(650 + 200 * std::tan(g) + 20, 400));
}

void test_piezo_set_point_beyond_the_xy_range_is_clamped_and_counted()
{
    // Section 12: 90 um x 90 um about the scanner's centre (frame A's origin).
    // A set point at (60, -50) um stops at (45, -45) um; every sample spent
    // with it is counted; back in range, the count stops.
    World w(scene_with("bending_offset"));
    w.command(Eigen::Vector2d(60000, -50000), 5, true);
    const int samples = 80000;   // 4 s at 20 kHz: at 20 um/s the piezo covers the 64 um
    for (int i = 0; i < samples; ++i) w.step();
    TEST_ASSERT_EQUAL_DOUBLE(45000.0, w.piezo().x());
    TEST_ASSERT_EQUAL_DOUBLE(-45000.0, w.piezo().y());
    TEST_ASSERT_EQUAL_INT64(samples, w.piezo_clamped_samples());
    w.command(Eigen::Vector2d(44000, -44000), 5, true);
    for (int i = 0; i < 100; ++i) w.step();
    TEST_ASSERT_EQUAL_INT64(samples, w.piezo_clamped_samples());
    // A scan point beyond the range is taken at the limit, and counted.
    const auto far = w.scan_point(50000, 0), edge = w.scan_point(45000, 0);
    TEST_ASSERT_EQUAL_DOUBLE(edge.height_nm, far.height_nm);
    TEST_ASSERT_EQUAL_INT64(1, w.scan_points_clamped());
}

void test_piezo_z_beyond_its_range_is_clamped_and_the_load_departs()
{
    // 5 um of z about the substrate's reference plane: on glass tilted by 20
    // deg the surface at y = -8 um stands 2912 nm high, beyond +2500 nm: z
    // stops at 2500 nm, the lever bends by the shortfall, and the normal force
    // is the set point plus k_n times it (rounding only: 1e-9). At y = +8 um the surface falls away: the tip
    // leaves it (the pull k_n x shortfall beats the adhesion), S_n = S_l = 0.
    const std::string text = with(with(with(kBase, "EFFECTS", "bending_offset"), "substrate: glass", "substrate: tilted_glass\n  slope_deg: 20"),
                                  "field_nm: 2000", "field_nm: 20000");
    const afm::Scene s = scene_from_text(text);
    World w(s);
    const double load = 5, kn = s.probe.spring_N_per_m, knKn = kn * s.probe.deflection_nm_per_V;
    w.command(Eigen::Vector2d(0, -8000), load, true);
    afm::sim::Sample smp{};
    for (int i = 0; i < 12000; ++i) smp = w.step();   // 8 um at 20 um/s, then rest
    const int64_t clamped = w.piezo_clamped_samples();
    // The deflection the set point needs includes the moment of F_x (eq. 1c;
    // scan angle 270: frames C and A coincide), held statically here.
    const double surface = -w.apex().y() * std::tan(20 * M_PI / 180);
    const double fx = w.tip_force().x(), h = w.lever().h, l = w.lever().l;
    const double fz = load + kn * (surface - (load + 2 * h / l * fx) / kn - 2500);
    std::printf("z %.3f nm over a surface at %.3f nm: F_z %.4f nN, S_n %.6f V; %lld samples clamped\n", smp.piezo_nm.z(), surface,
                w.tip_force().z(), smp.sn_v, static_cast<long long>(clamped));
    TEST_ASSERT_EQUAL_DOUBLE(2500.0, smp.piezo_nm.z());
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, fz, w.tip_force().z());
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, (fz + 2 * h / l * fx) / knKn, smp.sn_v);
    TEST_ASSERT_TRUE(clamped > 0 && clamped < 12000);
    w.command(Eigen::Vector2d(0, 8000), load, true);
    for (int i = 0; i < 20000; ++i) smp = w.step();
    TEST_ASSERT_EQUAL_DOUBLE(-2500.0, smp.piezo_nm.z());
    TEST_ASSERT_EQUAL_DOUBLE(0.0, smp.sn_v);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, smp.sl_v);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, w.tip_force().norm());
    TEST_ASSERT_TRUE(w.piezo_clamped_samples() > clamped);
}

void test_field_outside_the_scanner_range_is_refused_with_the_key_named()
{
    const std::string msg =
        scene_error(with(with(kBase, "EFFECTS", ""), "field_nm: 2000", "field_nm: 2000\n  field_center_nm: [44500, 0]"));
    TEST_ASSERT_TRUE_MESSAGE(msg.find("sample.field_center_nm") != std::string::npos, msg.c_str());
    TEST_ASSERT_TRUE_MESSAGE(msg.find("44500") != std::string::npos, msg.c_str());
    // The whole range as the field: accepted.
    TEST_ASSERT_EQUAL_DOUBLE(90000.0, scene_from_text(with(with(kBase, "EFFECTS", ""), "field_nm: 2000", "field_nm: 90000")).field_nm);
}

void test_included_calibration_is_read_and_the_scenes_own_values_win()
{
    // A lab's calibration (./afm calib ... --write) is a file a scene
    // includes: its probe and firmware keys fill what the scene leaves out.
    char inc[] = "/tmp/afm-test-include-XXXXXX";
    const int fd = mkstemp(inc);
    TEST_ASSERT_TRUE(fd >= 0);
    close(fd);
    std::ofstream(inc) << "probe: {cn_nm_per_V: 30.5, lever_length_um: 200}\nfirmware: {disp_n_nm_per_V: 29.0, mu: 0.2}\n";
    const std::string text = with(with(kBase, "EFFECTS", "bending_offset"), "name: unit",
                                  std::string("name: unit\ninclude: ") + inc + "\nprobe: {lever_length_um: 300}");
    const afm::Scene s = scene_from_text(text);
    TEST_ASSERT_TRUE(s.probe.cn_nm_per_V.has_value());
    TEST_ASSERT_EQUAL_DOUBLE(30.5, *s.probe.cn_nm_per_V);
    TEST_ASSERT_EQUAL_DOUBLE(300.0, s.probe.lever_length_um);   // the scene's own value wins
    TEST_ASSERT_EQUAL_DOUBLE(29.0, *s.fw_cal.disp_n_nm_per_V);
    TEST_ASSERT_EQUAL_DOUBLE(0.2, *s.fw_cal.mu);
    // The simulated lever's apex moves by the true C_n, not the beam's estimate.
    const afm::sim::Lever lv(s.probe);
    const double fz = 5.0;
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 30.5 * lv.sn_volts(0, fz), lv.apex_offset(Eigen::Vector2d::Zero(), fz).x());
    // An include with a key it may not hold, and one that is missing: named
    // by the file and the line, never quoted (an included file's content
    // stays unsaid: issue 46, include: of a root-only file).
    std::ofstream(inc) << "operator: {load_nN: 9}\n";
    std::string msg = scene_error(text);
    TEST_ASSERT_TRUE_MESSAGE(msg.find(inc + std::string(": line 1: a key other than probe, firmware or sample")) != std::string::npos,
                             msg.c_str());
    TEST_ASSERT_TRUE_MESSAGE(msg.find("operator") == std::string::npos && msg.find("load_nN") == std::string::npos, msg.c_str());
    unlink(inc);
    // Sites as a list survive the include and path resolution (a mapping
    // key looked up on a list must not turn it into a mapping).
    const std::string listed = with(with(with(kBase, "EFFECTS", ""), "objects:\n", "objects:\n  targets:\n    - [100, 0]\n    - [400, 0]\n"),
                                    "  load_nN: 5\n", "  load_nN: 5\n  plan: {}\n");
    const afm::Scene sites = scene_from_text(listed);
    TEST_ASSERT_EQUAL_INT(2, (int)sites.targets.sites_nm.size());
    msg = scene_error(text);
    TEST_ASSERT_TRUE_MESSAGE(msg.find(inc) != std::string::npos && msg.find("cannot open") != std::string::npos, msg.c_str());
}

// The z servo (afm.z_speed_nm_per_s) and the retract (kRetractLift_nm):
// a still tip on flat glass, rigid lever (no bending_offset: F_x = 0), so
// the force is exactly the set point plus k_n times the z still missing.
static afm::Scene servo_scene(double v_nm_per_s)
{
    std::string t = with(kBase, "EFFECTS", "");
    if (v_nm_per_s > 0) t = with(t, "frame_rate_hz: 25\n", "frame_rate_hz: 25\nafm:\n  z_speed_nm_per_s: " + std::to_string(v_nm_per_s) + "\n");
    return scene_from_text(t);
}

void test_ideal_z_servo_by_default_steps_the_force_to_the_set_point()
{
    // Speed 0 (the default, every existing scene): the force is the set
    // point from the first sample after it changes, as before (1e-9: rounding).
    const afm::Scene s = servo_scene(0);
    TEST_ASSERT_EQUAL_DOUBLE(0.0, s.z_speed_nm_per_s);
    World w(s);
    const double knKn = s.probe.spring_N_per_m * s.probe.deflection_nm_per_V;
    w.command(Eigen::Vector2d(0, -300), 5, true);
    afm::sim::Sample smp = w.step();
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 5.0, w.tip_force().z());
    w.command(Eigen::Vector2d(0, -300), 80, true);
    smp = w.step();
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 80.0, w.tip_force().z());
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 80.0 / knKn, smp.sn_v);
}

void test_finite_z_servo_raises_the_force_by_k_n_v_z_per_sample()
{
    // v_z = 20 um/s at 20 kHz: 1 nm of z per sample, k_n = 0.12 nN/nm: the
    // force climbs from 5 to 50 nN by 0.12 nN a sample (375 samples), then
    // holds; back down to 5 nN the same way. The first sample settles at
    // once (a run starts in contact at its load). Rounding only: 1e-9.
    const afm::Scene s = servo_scene(20000);
    TEST_ASSERT_EQUAL_DOUBLE(20000.0, s.z_speed_nm_per_s);
    World w(s);
    const double kn = s.probe.spring_N_per_m, knKn = kn * s.probe.deflection_nm_per_V, dz = 20000.0 / s.sample_rate_hz;
    w.command(Eigen::Vector2d(0, -300), 5, true);
    afm::sim::Sample smp = w.step();
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 5.0, w.tip_force().z());
    double z = smp.piezo_nm.z();
    w.command(Eigen::Vector2d(0, -300), 50, true);
    for (int m = 1; m <= 400; ++m) {
        smp = w.step();
        const double expected = std::min(50.0, 5.0 + kn * dz * m);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, expected, w.tip_force().z());
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, expected / knKn, smp.sn_v);
        TEST_ASSERT_TRUE(z - smp.piezo_nm.z() <= dz + 1e-9);   // z moves down at most v_z dt
        z = smp.piezo_nm.z();
    }
    w.command(Eigen::Vector2d(0, -300), 5, true);
    for (int m = 1; m <= 400; ++m) {
        w.step();
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, std::max(5.0, 50.0 - kn * dz * m), w.tip_force().z());
    }
    // The bound of the card's interlock, from this: a block of 20 samples
    // raises the force by at most k_n v_z T_block = 2.4 nN.
    std::printf("finite z servo: %.3f nN per sample, %.3f nN per block of %d samples\n", kn * dz, kn * dz * s.samples_per_block(),
                s.samples_per_block());
}

void test_disengaging_retracts_z_100_nm_at_once_and_the_servo_lands_it_again()
{
    for (const double v : {0.0, 20000.0}) {
        const afm::Scene s = servo_scene(v);
        World w(s);
        const double kn = s.probe.spring_N_per_m;
        w.command(Eigen::Vector2d(0, -300), 5, true);
        for (int i = 0; i < 10; ++i) w.step();
        const double z_load = w.piezo_z(), z_touch = z_load + 5.0 / kn;   // where the tip touches with no load
        // lifted: at once, and kept there
        w.command(Eigen::Vector2d(0, -300), 5, false);
        for (int i = 0; i < 50; ++i) {
            const afm::sim::Sample smp = w.step();
            TEST_ASSERT_DOUBLE_WITHIN(1e-9, z_touch + afm::sim::kRetractLift_nm, smp.piezo_nm.z());
            TEST_ASSERT_EQUAL_DOUBLE(0.0, w.tip_force().norm());
            TEST_ASSERT_EQUAL_DOUBLE(0.0, smp.sn_v);
        }
        w.command(Eigen::Vector2d(0, -300), 5, true);
        if (v == 0) {
            // the ideal servo lands it in the next sample
            w.step();
            TEST_ASSERT_DOUBLE_WITHIN(1e-9, 5.0, w.tip_force().z());
            TEST_ASSERT_DOUBLE_WITHIN(1e-9, z_load, w.piezo_z());
            continue;
        }
        // at 1 nm a sample: 100 samples to come down to the touching height
        // (no adhesion listed: no force there yet), then 0.12 nN a sample
        for (int m = 1; m <= 100; ++m) {
            w.step();
            TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.0, w.tip_force().z());
        }
        for (int m = 1; m <= 60; ++m) {
            w.step();
            TEST_ASSERT_DOUBLE_WITHIN(1e-9, std::min(5.0, 0.12 * m), w.tip_force().z());
        }
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, z_load, w.piezo_z());
    }
    // A speed below 0 is refused, naming the key.
    const std::string msg =
        scene_error(with(with(kBase, "EFFECTS", ""), "frame_rate_hz: 25\n", "frame_rate_hz: 25\nafm: {z_speed_nm_per_s: -1}\n"));
    TEST_ASSERT_TRUE_MESSAGE(msg.find("afm.z_speed_nm_per_s") != std::string::npos, msg.c_str());
}

// The grid's query is a superset of the points within the radius, in the
// order the cells hold them, whatever the points' moves: checked against a
// brute force over 2000 points moved at random, 10^4 points' worth far apart
// (keys that share the occupancy table's slots) and the empty grid.
static void test_grid_query_finds_every_point_within_the_radius_as_points_move(void)
{
    afm::sim::Grid empty(10.0);
    std::vector<int> out;
    empty.query(Eigen::Vector2d(0, 0), 25.0, out);
    TEST_ASSERT_TRUE(out.empty());

    const double cell = 110.0;
    afm::sim::Grid g(cell);
    std::vector<Eigen::Vector2d> pts;
    uint64_t s = 12345;
    auto uni = [&](double lo, double hi) {
        s = s * 6364136223846793005ull + 1442695040888963407ull;
        return lo + (hi - lo) * static_cast<double>(s >> 11) / 9007199254740992.0;
    };
    for (int i = 0; i < 2000; ++i) {
        // half in a 5 um field, half spread over 1e7 nm (sparse, many slots shared)
        const double span = i % 2 ? 2500.0 : 5e6;
        pts.emplace_back(uni(-span, span), uni(-span, span));
        g.insert(i, pts.back());
    }
    for (int round = 0; round < 4; ++round) {
        for (int i = 0; i < 2000; i += 3) {
            pts[i] += Eigen::Vector2d(uni(-300, 300), uni(-300, 300));
            g.update(i, pts[i]);
        }
        for (int q = 0; q < 500; ++q) {
            const Eigen::Vector2d p(uni(-3000, 3000), uni(-3000, 3000));
            const double r = uni(0, cell);
            out.clear();
            g.query(p, r, out);
            std::vector<char> seen(pts.size(), 0);
            for (int idx : out) {
                TEST_ASSERT_FALSE_MESSAGE(seen[idx], "a point listed twice");
                seen[idx] = 1;
            }
            for (std::size_t i = 0; i < pts.size(); ++i)
                if ((pts[i] - p).norm() <= r) TEST_ASSERT_TRUE_MESSAGE(seen[i], "a point within the radius missed");
        }
    }
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_particle_scene_builds_no_wire_drift_or_lithography_model);
    RUN_TEST(test_grid_query_finds_every_point_within_the_radius_as_points_move);
    RUN_TEST(test_drift_listed_runs_and_moves_the_sample);
    RUN_TEST(test_clocks_time_one_sample_in_sixteen);
    RUN_TEST(test_force_along_the_lever_reads_as_normal_load);
    RUN_TEST(test_apex_moves_forward_with_upward_bending);
    RUN_TEST(test_imaged_sphere_width_matches_tip_dilation_closed_form);
    RUN_TEST(test_thermal_noise_level_is_kT_over_k);
    RUN_TEST(test_pushed_particle_slides_at_its_threshold_in_contact_ahead);
    RUN_TEST(test_same_seed_same_trajectory);
    RUN_TEST(test_landmark_pillar_images_flat_top_and_tip_limited_edge);
    RUN_TEST(test_piezo_set_point_beyond_the_xy_range_is_clamped_and_counted);
    RUN_TEST(test_piezo_z_beyond_its_range_is_clamped_and_the_load_departs);
    RUN_TEST(test_field_outside_the_scanner_range_is_refused_with_the_key_named);
    RUN_TEST(test_included_calibration_is_read_and_the_scenes_own_values_win);
    RUN_TEST(test_ideal_z_servo_by_default_steps_the_force_to_the_set_point);
    RUN_TEST(test_finite_z_servo_raises_the_force_by_k_n_v_z_per_sample);
    RUN_TEST(test_disengaging_retracts_z_100_nm_at_once_and_the_servo_lands_it_again);
    return UNITY_END();
}
