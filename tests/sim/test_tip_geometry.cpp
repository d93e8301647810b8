// Unity tests of the tip's contact geometry in 3-D (sim_afm/tip_geometry.hpp)
// against closed forms in the plane through the axis and brute-force samples
// of the tip's surface (its own parametrisation: the apex's arc, then the
// generator, turned by elementary rotations written out here). Tolerances
// are stated per test, with their reason.
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

#include "tip_geometry.hpp"
#include "world.hpp"

using afm::sim::HeightSearch;
using afm::sim::TipContact;
using afm::sim::TipGeometry;
using afm::sim::TipPart;
using afm::sim::TipPose;
using Eigen::Vector2d;
using Eigen::Vector3d;

namespace {

constexpr double kR = 10.0;                  // the paper's apex radius, nm
constexpr double kGamma = 20.0 * M_PI / 180; // its cone half angle

TipGeometry upright(const Vector3d &apex = Vector3d::Zero(), double r = kR, double g = kGamma)
{
    TipPose p;
    p.apex_nm = apex;
    return TipGeometry(r, g, p);
}

// The flank's radius at height H above the apex of an upright tip (the
// imaging's tip_profile, inverted), nm.
double cone_radius(double H) { return kR * std::cos(kGamma) + (H - kR * (1 - std::sin(kGamma))) * std::tan(kGamma); }

// Where an upright tip on the substrate first touches a ball of radius r
// resting on it: the horizontal distance of the ball's centre from the
// apex, with the flank touching (the ball's centre r from the generator's
// line at the centre's height r).
double flank_contact_distance(double r) { return cone_radius(r) + r / std::cos(kGamma); }

// Elementary rotations, written out (the library composes Eigen's).
Eigen::Matrix3d rot_x(double a) { Eigen::Matrix3d m; m << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a); return m; }
Eigen::Matrix3d rot_y(double a) { Eigen::Matrix3d m; m << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a); return m; }
Eigen::Matrix3d rot_z(double a) { Eigen::Matrix3d m; m << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1; return m; }

// The tip's surface at azimuth phi and arc length s from the apex along its
// profile: the apex's arc up to the tangent circle, then the generator.
Vector3d surface_at(const TipPose &pose, double phi, double s)
{
    const double arc = kR * (M_PI / 2 - kGamma);
    double u, z;
    if (s <= arc) {
        u = kR * std::sin(s / kR);
        z = kR - kR * std::cos(s / kR);
    } else {
        u = kR * std::cos(kGamma) + (s - arc) * std::sin(kGamma);
        z = kR - kR * std::sin(kGamma) + (s - arc) * std::cos(kGamma);
    }
    const Eigen::Matrix3d turn = rot_z(pose.alpha_rad) * rot_x(pose.twist_rad) * rot_y(-pose.tilt_rad);
    return pose.apex_nm + turn * Vector3d(u * std::cos(phi), u * std::sin(phi), z);
}

// Brute force: the least distance from q to the sampled surface (q outside
// the tip), by grids over (phi, s) refined about the best sample 8 times;
// while the s window holds the apex (the pole, where every phi meets) the
// grid keeps every azimuth.
double brute_distance(const TipPose &pose, const Vector3d &q, double s_max, Vector3d *nearest = nullptr)
{
    double best = INFINITY, bphi = 0, bs = 0;
    double phi0 = -M_PI, phi1 = M_PI, s0 = 0, s1 = s_max;
    for (int level = 0; level < 8; ++level) {
        const int n = level == 0 ? 720 : 60, nphi = phi1 - phi0 > 6 ? 720 : 60;
        const double dphi = (phi1 - phi0) / nphi, ds = (s1 - s0) / n;
        for (int i = 0; i <= nphi; ++i)
            for (int j = 0; j <= n; ++j) {
                const double phi = phi0 + i * dphi, s = std::max(0.0, s0 + j * ds);
                const double d = (surface_at(pose, phi, s) - q).norm();
                if (d < best) best = d, bphi = phi, bs = s;
            }
        s0 = bs - 3 * ds, s1 = bs + 3 * ds;
        if (s0 > 0) phi0 = bphi - 3 * dphi, phi1 = bphi + 3 * dphi;
    }
    if (nearest) *nearest = surface_at(pose, bphi, bs);
    return best;
}

void assert_unit(const Vector3d &n) { TEST_ASSERT_DOUBLE_WITHIN(1e-12, 1.0, n.norm()); }

void assert_vec(double tol, const Vector3d &want, const Vector3d &got, const char *what)
{
    char msg[200];
    std::snprintf(msg, sizeof msg, "%s: want (%.9g, %.9g, %.9g), got (%.9g, %.9g, %.9g)", what, want.x(), want.y(), want.z(),
                  got.x(), got.y(), got.z());
    TEST_ASSERT_TRUE_MESSAGE((want - got).norm() <= tol, msg);
}

// The horizontal distance (along +x) at which a sphere of radius r on the
// substrate first touches the upright tip on the substrate: bisection on the
// library's gap, to 1e-9 nm.
double contact_distance(double r)
{
    const TipGeometry tip = upright();
    double lo = 0, hi = 10 * r + 100;
    while (hi - lo > 1e-9) {
        const double mid = 0.5 * (lo + hi);
        (tip.sphere(Vector3d(mid, 0, r), r).gap_nm > 0 ? hi : lo) = mid;
    }
    return 0.5 * (lo + hi);
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_axis_follows_the_levers_tilt_twist_and_alpha()
{
    // Tilt swings the apex to +x_C (the axis, apex -> lever, leans to -x),
    // twist to +y_C, alpha turns C into A: Lever's signs.
    const double a = 0.3;
    TipPose p;
    p.tilt_rad = a;
    assert_vec(1e-15, Vector3d(-std::sin(a), 0, std::cos(a)), TipGeometry(kR, kGamma, p).axis(), "tilt");
    p = TipPose{};
    p.twist_rad = a;
    assert_vec(1e-15, Vector3d(0, -std::sin(a), std::cos(a)), TipGeometry(kR, kGamma, p).axis(), "twist");
    p.alpha_rad = M_PI / 2;   // C's -y is A's +x
    assert_vec(1e-15, Vector3d(std::sin(a), 0, std::cos(a)), TipGeometry(kR, kGamma, p).axis(), "twist, alpha 90 deg");
}

void test_sphere_below_the_apex_touches_it_with_a_vertical_normal()
{
    const TipContact c = upright().sphere(Vector3d(0, 0, -57), 50);   // 7 nm below the apex
    TEST_ASSERT_TRUE(c.part == TipPart::apex);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 7.0, c.gap_nm);
    assert_vec(1e-15, Vector3d::UnitZ(), c.normal, "normal");
    assert_vec(1e-12, Vector3d::Zero(), c.on_tip_nm, "on the tip");
    assert_vec(1e-12, Vector3d(0, 0, -7), c.on_object_nm, "on the sphere");
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, c.axial_nm);
}

void test_sphere_beside_the_flank_has_the_flanks_normal()
{
    // A ball at +y, its centre 300 nm up: the flank's generator line at
    // distance (rho - cone_radius) cos gamma; the normal leans away from the
    // tip's side by gamma from the horizontal.
    const double H = 300, rho = 400, r = 30;
    const TipContact c = upright().sphere(Vector3d(0, rho, H), r);
    TEST_ASSERT_TRUE(c.part == TipPart::flank);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, (rho - cone_radius(H)) * std::cos(kGamma) - r, c.gap_nm);
    assert_vec(1e-14, Vector3d(0, -std::cos(kGamma), std::sin(kGamma)), c.normal, "normal");
    assert_unit(c.normal);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, c.gap_nm, (c.on_tip_nm - c.on_object_nm).dot(c.normal));
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, cone_radius(c.axial_nm), c.on_tip_nm.y());   // on the flank's surface
}

void test_4um_sphere_flank_touches_first_matching_a_brute_force_sample()
{
    // A 4 um ball on the substrate and the paper's tip on it: at the 3-D
    // contact the flank touches (the apex's own sphere is far off), and the
    // gap at several places matches a brute-force sample of the surface
    // within 0.01 nm (the centre is outside the tip at each).
    const double r = 2000;
    const TipGeometry tip = upright();
    const double d3 = contact_distance(r);
    const TipContact at = tip.sphere(Vector3d(d3, 0, r), r);
    TEST_ASSERT_TRUE(at.part == TipPart::flank);
    TEST_ASSERT_DOUBLE_WITHIN(1e-8, 0.0, at.gap_nm);
    TEST_ASSERT_TRUE((Vector3d(d3, 0, r) - tip.apex_centre()).norm() - kR - r > 500);   // the apex is 500+ nm clear
    for (const double d : {d3, d3 - 300, 2010.0, 2600.0}) {
        const Vector3d c(d, 0, r);
        const double want = brute_distance(TipPose{}, c, 6000) - r;
        const double got = tip.sphere(c, r).gap_nm;
        char msg[120];
        std::snprintf(msg, sizeof msg, "d %.3f nm: gap %.6f nm, brute force %.6f nm", d, got, want);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(0.01, want, got, msg);
    }
}

void test_4um_sphere_planar_contact_is_about_850_nm_off()
{
    // The planar rule touches at R + r = 2010 nm; the flank at the closed
    // form's distance, 853 nm further out (the 850 nm: the shank
    // ends that far inside the ball).
    const double d3 = contact_distance(2000);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, flank_contact_distance(2000), d3);
    std::printf("4 um sphere: 3-D contact at %.3f nm, planar at 2010 nm: %.1f nm apart\n", d3, d3 - 2010);
    TEST_ASSERT_DOUBLE_WITHIN(15.0, 850.0, d3 - 2010);
    // At the planar rule's contact the 3-D gap is some 800 nm of overlap.
    TEST_ASSERT_TRUE(upright().sphere(Vector3d(2010, 0, 2000), 2000).gap_nm < -790);
}

void test_paper_100nm_sphere_and_rod_planar_error_is_about_18_nm()
{
    // A 100 nm latex ball and a 100 nm rod (its axis across x) on the
    // substrate: both touch the flank at the same distance (a horizontal
    // line's point nearest an upright cone is its foot from the axis), 18 nm
    // beyond the planar rule's R + r = 60 nm.
    const double r = 50, d3 = contact_distance(r);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, flank_contact_distance(r), d3);
    std::printf("100 nm objects: 3-D contact at %.4f nm, planar at 60 nm: %.2f nm apart\n", d3, d3 - 60);
    TEST_ASSERT_DOUBLE_WITHIN(1.0, 18.0, d3 - 60);
    const TipGeometry tip = upright();
    for (const double d : {d3, d3 + 5, 61.0}) {
        const TipContact rod = tip.cylinder(Vector3d(d, -650, r), Vector3d(d, 650, r), r);
        const TipContact ball = tip.sphere(Vector3d(d, 0, r), r);
        TEST_ASSERT_TRUE(rod.part == TipPart::flank);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, ball.gap_nm, rod.gap_nm);
        assert_vec(1e-9, ball.normal, rod.normal, "rod's normal");
        TEST_ASSERT_DOUBLE_WITHIN(1e-6, 0.0, rod.on_object_nm.y());
    }
}

void test_tilted_tip_matches_the_brute_force_sample()
{
    // A tip tilted, twisted and turned, against balls all round it: gap
    // within 0.01 nm and normal within 1e-3 of the brute force's (its
    // nearest sample to the centre; the sample's spacing limits both).
    TipPose pose;
    pose.apex_nm = Vector3d(5, -3, 2);
    pose.tilt_rad = 0.2, pose.twist_rad = -0.12, pose.alpha_rad = 0.7;
    const TipGeometry tip(kR, kGamma, pose);
    const Vector3d balls[] = {{80, 10, 50}, {-70, 20, 50}, {10, 75, 40}, {0, -90, 60}, {6, -3, -40}, {40, 0, -10}, {1300, -200, 2000}};
    const double radii[] = {50, 50, 40, 60, 40, 20, 2000};
    bool saw_flank = false, saw_apex = false;
    for (int i = 0; i < 7; ++i) {
        TEST_ASSERT_TRUE(tip.nearest(balls[i]).sd_nm > 0);   // the brute force's distance is unsigned
        Vector3d near;
        const double want = brute_distance(pose, balls[i], 6000, &near) - radii[i];
        const TipContact c = tip.sphere(balls[i], radii[i]);
        char msg[120];
        std::snprintf(msg, sizeof msg, "ball %d: gap %.6f nm, brute force %.6f nm", i, c.gap_nm, want);
        TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(0.01, want, c.gap_nm, msg);
        assert_vec(1e-3, (near - balls[i]).normalized(), c.normal, msg);
        (c.part == TipPart::flank ? saw_flank : saw_apex) = true;
    }
    TEST_ASSERT_TRUE(saw_flank && saw_apex);
}

void test_gap_and_normal_are_continuous_across_the_apex_flank_boundary()
{
    // A 5 nm ball moved across x at 5 nm below the apex centre: its contact
    // passes from the apex to the flank (at rho = 5 / tan gamma). The gap is
    // 1-Lipschitz; the normal turns at most step / 5 nm per step.
    const TipGeometry tip = upright();
    const double z = kR - 5, step = 0.01;
    TipContact last = tip.sphere(Vector3d(0.5, 0, z), 5);
    int switches = 0;
    for (double x = 0.5 + step; x < 40; x += step) {
        const TipContact c = tip.sphere(Vector3d(x, 0, z), 5);
        TEST_ASSERT_TRUE(std::fabs(c.gap_nm - last.gap_nm) <= step * (1 + 1e-9));
        TEST_ASSERT_TRUE((c.normal - last.normal).norm() <= step / 5);
        switches += c.part != last.part;
        last = c;
    }
    TEST_ASSERT_EQUAL_INT(1, switches);
    const double xb = 5 / std::tan(kGamma);
    const TipContact below = tip.sphere(Vector3d(xb - 1e-9, 0, z), 5), above = tip.sphere(Vector3d(xb + 1e-9, 0, z), 5);
    TEST_ASSERT_TRUE(below.part == TipPart::apex && above.part == TipPart::flank);
    TEST_ASSERT_DOUBLE_WITHIN(1e-8, below.gap_nm, above.gap_nm);
    assert_vec(1e-8, below.normal, above.normal, "normal across the boundary");
}

void test_cylinder_under_the_apex_is_the_segment_point_distance()
{
    // An oblique rod below the apex: the apex's sphere touches, the gap is
    // the distance from its centre to the axis less both radii.
    TipPose pose;
    pose.tilt_rad = 0.1;
    const TipGeometry tip(kR, kGamma, pose);
    const Vector3d a(-300, -200, -40), b(250, 260, -35);
    const double t = (tip.apex_centre() - a).dot(b - a) / (b - a).squaredNorm();
    const Vector3d foot = a + t * (b - a);
    const TipContact c = tip.cylinder(a, b, 25);
    TEST_ASSERT_TRUE(c.part == TipPart::apex);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, (tip.apex_centre() - foot).norm() - kR - 25, c.gap_nm);
    assert_vec(1e-12, (tip.apex_centre() - foot).normalized(), c.normal, "normal");
}

void test_cylinder_on_a_tilted_flank_is_its_least_ball()
{
    // A rod beside a tilted tip's flank: the gap no larger than any ball's
    // along its axis (sampled every 0.01 nm near the least) and within
    // 1e-5 nm of the least sampled (the samples' spacing, squared, over the
    // flank's radius there).
    TipPose pose;
    pose.tilt_rad = 0.25, pose.twist_rad = 0.1;
    const TipGeometry tip(kR, kGamma, pose);
    const Vector3d a(60, -400, 30), b(140, 500, 120);
    const TipContact c = tip.cylinder(a, b, 30);
    TEST_ASSERT_TRUE(c.part == TipPart::flank);
    double least = INFINITY;
    const double u0 = (c.on_object_nm - a).dot(b - a) / (b - a).squaredNorm();
    for (int i = -2000; i <= 2000; ++i) {
        const double u = u0 + i * 1e-5;
        if (u >= 0 && u <= 1) least = std::min(least, tip.sphere(a + u * (b - a), 30).gap_nm);
    }
    TEST_ASSERT_TRUE(c.gap_nm <= least + 1e-12);
    TEST_ASSERT_DOUBLE_WITHIN(1e-5, least, c.gap_nm);
    for (int i = 0; i <= 1000; ++i) TEST_ASSERT_TRUE(c.gap_nm <= tip.sphere(a + i / 1000.0 * (b - a), 30).gap_nm + 1e-12);
}

void test_cylinder_parallel_to_the_tip_axis_touches_at_its_top_end()
{
    // Upright beside an upright tip: the cone widens upwards, so the top
    // end's cap touches first.
    const TipGeometry tip = upright();
    const Vector3d a(200, 0, 0), b(200, 0, 300);
    const TipContact c = tip.cylinder(a, b, 20), top = tip.sphere(b, 20);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, top.gap_nm, c.gap_nm);
    assert_vec(1e-12, top.normal, c.normal, "normal");
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, (200 - cone_radius(300)) * std::cos(kGamma) - 20, c.gap_nm);
}

void test_cylinder_along_a_generator_has_the_flat_gap()
{
    // A rod parallel to the flank's generator, 12 nm out from its line: the
    // gap is 12 - r all along; any point of it is a least one.
    const TipGeometry tip = upright();
    const Vector3d g(std::sin(kGamma), 0, std::cos(kGamma)), out(std::cos(kGamma), 0, -std::sin(kGamma));
    const Vector3d base(cone_radius(100), 0, 100);   // on the flank
    const TipContact c = tip.cylinder(base + 12 * out, base + 12 * out + 500 * g, 4);
    TEST_ASSERT_TRUE(c.part == TipPart::flank);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 8.0, c.gap_nm);
    assert_vec(1e-12, -out, c.normal, "normal");
}

void test_zero_length_cylinder_is_a_sphere_and_on_axis_centres_stay_finite()
{
    const TipGeometry tip = upright();
    const Vector3d p(30, 40, 60);
    const TipContact c = tip.cylinder(p, p, 15), s = tip.sphere(p, 15);
    TEST_ASSERT_EQUAL_DOUBLE(s.gap_nm, c.gap_nm);
    assert_vec(0, s.normal, c.normal, "zero length");
    // Centres on the axis: below the apex, at the apex centre, deep inside.
    const TipContact at_centre = tip.sphere(tip.apex_centre(), 1);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, -kR - 1, at_centre.gap_nm);
    assert_unit(at_centre.normal);
    const TipContact deep = tip.sphere(Vector3d(0, 0, 500), 1);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, -(500 - kR) * std::sin(kGamma) - kR - 1, deep.gap_nm);
    assert_unit(deep.normal);
    const TipContact through = tip.cylinder(Vector3d(0, 0, -100), Vector3d(0, 0, 100), 1);   // along the axis
    TEST_ASSERT_TRUE(std::isfinite(through.gap_nm));
    assert_unit(through.normal);
}

void test_half_angle_at_and_near_0_and_90_deg_stays_well_conditioned()
{
    // 0: a cylinder of radius R with a hemispherical end; pi/2: the plane
    // tangent to the apex. The same answers a hair inside the range.
    for (const double g : {0.0, 1e-12}) {
        const TipContact c = upright(Vector3d::Zero(), kR, g).sphere(Vector3d(60, 0, 500), 20);
        TEST_ASSERT_TRUE(c.part == TipPart::flank);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, 60 - kR - 20, c.gap_nm);
        assert_vec(1e-9, -Vector3d::UnitX(), c.normal, "gamma 0");
    }
    for (const double g : {M_PI / 2, M_PI / 2 - 1e-12}) {
        const TipGeometry flat = upright(Vector3d::Zero(), kR, g);
        for (const Vector3d &q : {Vector3d(0, 0, -30), Vector3d(400, -300, -30)}) {
            const TipContact c = flat.sphere(q, 20);
            TEST_ASSERT_DOUBLE_WITHIN(1e-9, 10.0, c.gap_nm);
            assert_vec(1e-9, Vector3d::UnitZ(), c.normal, "gamma 90 deg");
        }
    }
}

void test_out_of_range_arguments_are_refused_naming_the_value()
{
    auto refused = [](auto f, const char *word) {
        try {
            f();
        } catch (const std::invalid_argument &e) {
            TEST_ASSERT_NOT_NULL_MESSAGE(std::strstr(e.what(), word), e.what());
            return;
        }
        TEST_FAIL_MESSAGE(word);
    };
    const TipGeometry tip = upright();
    refused([] { upright(Vector3d::Zero(), kR, -0.01); }, "half_angle_rad -0.01");
    refused([] { upright(Vector3d::Zero(), kR, 1.6); }, "half_angle_rad 1.6");
    refused([] { upright(Vector3d::Zero(), kR, NAN); }, "half_angle_rad nan");
    refused([] { upright(Vector3d::Zero(), -1, kGamma); }, "radius_nm -1");
    refused([&] { tip.sphere(Vector3d::Zero(), -2); }, "sphere radius_nm -2");
    refused([&] { tip.cylinder(Vector3d::Zero(), Vector3d(NAN, 0, 0), 2); }, "end point");
    const auto flat = [](const Vector2d &) { return 0.0; };
    refused([&] { tip.height_field(flat, HeightSearch{50, 0, 1e-6, 2}); }, "pitch_nm 0");
    refused([&] { tip.height_field(flat, HeightSearch{5000, 1, 1e-6, 2}); }, "radius_nm 5000");
    refused([&] { tip.height_field(flat, HeightSearch{50, 1, 2, 2}); }, "tol_nm 2");
    refused([&] { tip.height_field(flat, HeightSearch{50, 1, 1e-6, 0}); }, "starts 0");
    refused([&] { tip.height_field([](const Vector2d &q) { return q.x() > 3 ? NAN : 0.0; }); }, "not a finite height");
}

void test_planes_touch_the_apex_with_their_normal()
{
    // Flat and 30 deg planes under the apex: the gap is the apex centre's
    // distance to the plane less R, within the search's tolerance.
    const TipGeometry tip = upright(Vector3d(0, 0, 3));
    for (const double slope : {0.0, 30.0}) {
        const double t = std::tan(slope * M_PI / 180), c = std::cos(slope * M_PI / 180);
        const TipContact k = tip.height_field([t](const Vector2d &q) { return q.x() * t; });
        TEST_ASSERT_TRUE(k.part == TipPart::apex);
        TEST_ASSERT_DOUBLE_WITHIN(1e-8, (3 + kR) * c - kR, k.gap_nm);
        assert_vec(1e-6, Vector3d(-t, 0, 1).normalized(), k.normal, "plane's normal");
    }
}

void test_trench_edge_is_touched_by_the_flank()
{
    // A 200 nm deep step, the apex 5 nm above the trench's floor and 80 nm
    // from the edge: the flank meets the edge's corner (closer than the
    // floor), at the gap of that corner point in the plane through the
    // axis, with the normal from the corner to the flank. The edge along y
    // and turned by 30 deg (not along the search's rays), at two
    // tolerances: the gap within 2 tol, the normal within twice the header's
    // sqrt(2 tol / r) (r: the flank's radius at the edge).
    const double D = 200, off = 80, H = D - 5;
    const double want = (off - cone_radius(H)) * std::cos(kGamma);
    TEST_ASSERT_TRUE(want > 0 && want < 5);
    for (const double tol : {1e-6, 1e-9})
        for (const double turn : {0.0, 30.0}) {
            const Vector2d u(std::cos(turn * M_PI / 180), std::sin(turn * M_PI / 180)), e0(17, -11);
            const auto step = [=](const Vector2d &q) { return (q - e0).dot(u) < 0 ? 0.0 : -D; };
            const Vector2d a = e0 + off * u + Vector2d(-u.y(), u.x()) * 7.0;
            const TipGeometry tip = upright(Vector3d(a.x(), a.y(), -D + 5));
            const TipContact c = tip.height_field(step, HeightSearch{100, 1, tol, 2});
            char msg[160];
            std::snprintf(msg, sizeof msg, "edge at %.0f deg, tol %g nm: gap %.12f nm, want %.12f nm", turn, tol, c.gap_nm, want);
            TEST_ASSERT_TRUE_MESSAGE(c.part == TipPart::flank, msg);
            TEST_ASSERT_DOUBLE_WITHIN_MESSAGE(2 * tol, want, c.gap_nm, msg);
            const Vector3d n(std::cos(kGamma) * u.x(), std::cos(kGamma) * u.y(), std::sin(kGamma));
            assert_vec(2 * std::sqrt(2 * tol / cone_radius(H)), n, c.normal, msg);
            TEST_ASSERT_DOUBLE_WITHIN(0.0, 0.0, c.on_object_nm.z());
        }
}

void test_rough_substrate_contact_has_its_surface_normal()
{
    // The project's rough surface (RoughSurface, its own gradient): at the
    // least gap the normal is the surface's, and no point of a fine sample
    // about it lies nearer the tip.
    const afm::sim::RoughSurface rough(3.0, 15.0, 7);
    const auto z = [&](const Vector2d &q) { return rough.height(q); };
    const TipGeometry tip = upright(Vector3d(4, -6, rough.height(Vector2d(4, -6)) + 4));
    const TipContact c = tip.height_field(z, HeightSearch{30, 0.5, 1e-6, 3});
    const Vector2d g = rough.gradient(c.on_object_nm.head<2>());
    assert_vec(1e-5, Vector3d(-g.x(), -g.y(), 1).normalized(), c.normal, "surface normal");
    const Vector2d p = c.on_object_nm.head<2>();
    for (int i = -40; i <= 40; ++i)
        for (int j = -40; j <= 40; ++j) {
            const Vector2d q = p + 0.05 * Vector2d(i, j);
            TEST_ASSERT_TRUE(c.gap_nm <= tip.nearest(Vector3d(q.x(), q.y(), z(q))).sd_nm + 1e-9);
        }
}

// A rod lying on the substrate, square to x, its axis at height r a
// distance s from the upright tip's axis (the apex on the substrate):
// pressed into the flank, its depth and normal in closed form (the
// flank's line in the plane through the axis: rho cos gamma - sigma sin
// gamma = R, the rod's axis r from it, sigma = r - R above the apex's
// centre), and the contact where the ball of its radius would be.
void test_rod_on_the_flank_has_the_closed_form_depth_and_normal()
{
    const TipGeometry tip = upright();
    const double r = 50;
    for (const double s : {60.0, 70.0, 78.0, 90.0}) {
        const TipContact c = tip.cylinder(Vector3d(s, -500, r), Vector3d(s, 500, r), r);
        const double want = s * std::cos(kGamma) - (r - kR) * std::sin(kGamma) - kR - r;
        TEST_ASSERT_TRUE(c.part == TipPart::flank);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, want, c.gap_nm);
        assert_unit(c.normal);
        assert_vec(1e-9, Vector3d(-std::cos(kGamma), 0, std::sin(kGamma)), c.normal, "flank normal");
    }
    // Its resting reach (gap 0) is the ball's, in closed form on the flank:
    // s = (r + R + (r - R) sin gamma) / cos gamma (78.41 nm), and on the
    // apex for a ball smaller than it, s = 2 sqrt(R r).
    const double flank = (r + kR + (r - kR) * std::sin(kGamma)) / std::cos(kGamma);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, flank, tip.resting_reach_nm(r, Vector2d::UnitX(), true));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, flank, tip.resting_reach_nm(r, Vector2d(0.6, -0.8), false));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, flank_contact_distance(2000), tip.resting_reach_nm(2000, Vector2d::UnitY(), false));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 2 * std::sqrt(kR * 1.0), tip.resting_reach_nm(1.0, Vector2d::UnitX(), false));
    TEST_ASSERT_DOUBLE_WITHIN(1e-6, 2 * std::sqrt(kR * 1.0), tip.resting_reach_nm(1.0, Vector2d::UnitX(), true));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, tip.resting_reach_nm(0.0, Vector2d::UnitX(), false));
}

// The hard cases: the tip exactly above the rod's axis (the normal
// vertical, the gap the apex's height over the rod's top), a cone's half
// angle a hair below 90 deg (the reach far out but finite), and refusals.
void test_rod_under_the_apex_and_a_flat_cone_stay_well_conditioned()
{
    const double r = 50;
    for (const double h : {0.0, -3.0, 7.5}) {
        const TipContact c = upright(Vector3d(0, 0, 2 * r + h)).cylinder(Vector3d(0, -500, r), Vector3d(0, 500, r), r);
        TEST_ASSERT_TRUE(c.part == TipPart::apex);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, h, c.gap_nm);
        assert_vec(1e-12, Vector3d::UnitZ(), c.normal, "above the axis");
    }
    const double g = M_PI / 2 - 1e-3;   // 89.94 deg: the flank's line s cos g - (r - R) sin g = R + r
    const TipGeometry flat = upright(Vector3d::Zero(), kR, g);
    const double want = (r + kR + (r - kR) * std::sin(g)) / std::cos(g);
    TEST_ASSERT_DOUBLE_WITHIN(1e-6 * want, want, flat.resting_reach_nm(r, Vector2d::UnitX(), true));
    auto refused = [](auto f, const char *word) {
        try {
            f();
        } catch (const std::invalid_argument &e) {
            TEST_ASSERT_NOT_NULL_MESSAGE(std::strstr(e.what(), word), e.what());
            return;
        }
        TEST_FAIL_MESSAGE(word);
    };
    refused([] { upright(Vector3d::Zero(), kR, M_PI / 2).resting_reach_nm(5, Vector2d::UnitX(), false); }, "no reach");
    refused([] { upright().resting_reach_nm(-1, Vector2d::UnitX(), false); }, "reach radius_nm -1");
    refused([] { upright().resting_reach_nm(1, Vector2d(1, 1), false); }, "not a unit vector");
}

namespace {
// The paper's lever with its twist made soft (theta of some degrees under a
// push of tens of nN: the lift-off's pose matters), scan angle 270 (C = A).
afm::sim::Lever soft_lever(double lateral_nN_per_V)
{
    afm::ProbeSpec p;
    p.lateral_nN_per_V = lateral_nN_per_V;
    p.tip_radius_nm = kR;
    p.tip_half_angle_deg = kGamma * 180 / M_PI;
    return afm::sim::Lever(p);
}

// A rod of radius 50 along x_C at y = the resting reach ahead of the apex,
// pushed along +y (across the lever: the twist, not the tilt, turns the
// flank), lift the load plus the adhesion.
afm::sim::LiftInput rod_ahead(double lift, double friction, double gamma = kGamma)
{
    const double r = 50;
    afm::sim::LiftInput in;
    in.radius_nm = kR;
    in.half_angle_rad = gamma;
    in.motion = Vector2d::UnitY();
    const double y = upright(Vector3d::Zero(), kR, gamma).resting_reach_nm(r, Vector2d::UnitY(), true);
    in.a = Vector3d(-650, y, r);
    in.b = Vector3d(650, y, r);
    in.cylinder_radius_nm = r;
    in.load_nN = lift;
    in.lift_nN = lift;
    in.friction_nN = friction;
    return in;
}

// The hand-derived balance: the push H on a flank at psi = gamma + theta
// from the horizontal lifts the tip by H tan psi, theta the lever's twist
// (F_y h / k_theta) under the push plus the tip's friction; H tan psi =
// lift, solved by bisection (H tan psi grows with H).
double hand_balance(const afm::sim::Lever &lever, double lift, double friction, double gamma = kGamma)
{
    double lo = 0, hi = lift / std::tan(gamma) + 1;
    for (int i = 0; i < 200; ++i) {
        const double H = 0.5 * (lo + hi);
        const double psi = gamma + (H + friction) * lever.h / lever.ktheta;
        (H * std::tan(psi) < lift ? lo : hi) = H;
    }
    return 0.5 * (lo + hi);
}
}  // namespace

// The lift-off push of a rod on a flat from the 3-D contact (lift_off_push)
// against the hand-derived balance, within 1 % (it agrees to about 1e-6:
// the lever's tilt under the load turns the flank at second order only),
// on the paper's lever and on a soft one (theta several degrees).
void test_rod_lift_off_push_matches_the_hand_derived_balance()
{
    for (const double lateral : {37.9, 2.0}) {
        const afm::sim::Lever lever = soft_lever(lateral);
        for (const double lift : {1.0, 6.0, 40.0}) {
            const afm::sim::LiftOff got = afm::sim::lift_off_push(lever, rod_ahead(lift, 0.5));
            const double want = hand_balance(lever, lift, 0.5);
            char msg[160];
            std::snprintf(msg, sizeof msg, "lateral %g nN/V, lift %g nN: want %.6f, got %.6f (%d steps)", lateral, lift, want,
                          got.push_nN, got.iterations);
            TEST_ASSERT_TRUE(got.part == TipPart::flank);
            TEST_ASSERT_TRUE_MESSAGE(std::fabs(got.push_nN - want) <= 0.01 * want, msg);
            // On the soft lever the twist matters: the push falls short of the
            // upright tip's lift / tan gamma by more than the tolerance.
            if (lateral < 10 && lift >= 6) TEST_ASSERT_TRUE_MESSAGE(got.push_nN < 0.97 * lift / std::tan(kGamma), msg);
        }
    }
}

// The lift-off's hard cases: zero load (adhesion alone: its push; nothing
// at all: 0), a cone near 90 deg (the push lift cot(psi), small but
// finite), the apex above the rod's axis (the normal vertical: no push
// holds the tip down, 0), and a cylindrical tip (its flank vertical, gamma 0): no lift.
void test_rod_lift_off_hard_cases()
{
    const afm::sim::Lever lever = soft_lever(37.9);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 0.0, afm::sim::lift_off_push(lever, rod_ahead(0.0, 0.0)).push_nN);
    const double adh = afm::sim::lift_off_push(lever, rod_ahead(1.0, 0.0)).push_nN;
    TEST_ASSERT_DOUBLE_WITHIN(0.01 * adh, hand_balance(lever, 1.0, 0.0), adh);
    const double g = M_PI / 2 - 1e-3;
    // (there cot psi is 1e-3: the lever's tilt under a load, some 1e-4 rad,
    // would move it by tens of %, so the lift is the adhesion's, no load)
    afm::sim::LiftInput steep = rod_ahead(5.0, 0.0, g);
    steep.load_nN = 0;
    const double flat = afm::sim::lift_off_push(lever, steep).push_nN;
    TEST_ASSERT_TRUE(std::isfinite(flat));
    TEST_ASSERT_DOUBLE_WITHIN(0.01 * flat, hand_balance(lever, 5.0, 0.0, g), flat);
    afm::sim::LiftInput above = rod_ahead(5.0, 0.0);
    above.a.y() = above.b.y() = 0;   // the rod's axis under the apex: the apex at its top
    above.a.z() = above.b.z() = -50;
    const afm::sim::LiftOff top = afm::sim::lift_off_push(lever, above);
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.0, top.push_nN);
    // A cylindrical tip (gamma 0): its flank's normal is horizontal, no
    // push lifts it (n_z 0 to rounding: infinite, or beyond any push).
    const double never = afm::sim::lift_off_push(lever, rod_ahead(5.0, 0.0, 0.0)).push_nN;
    TEST_ASSERT_TRUE(never > 1e9);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_axis_follows_the_levers_tilt_twist_and_alpha);
    RUN_TEST(test_sphere_below_the_apex_touches_it_with_a_vertical_normal);
    RUN_TEST(test_sphere_beside_the_flank_has_the_flanks_normal);
    RUN_TEST(test_4um_sphere_flank_touches_first_matching_a_brute_force_sample);
    RUN_TEST(test_4um_sphere_planar_contact_is_about_850_nm_off);
    RUN_TEST(test_paper_100nm_sphere_and_rod_planar_error_is_about_18_nm);
    RUN_TEST(test_tilted_tip_matches_the_brute_force_sample);
    RUN_TEST(test_gap_and_normal_are_continuous_across_the_apex_flank_boundary);
    RUN_TEST(test_cylinder_under_the_apex_is_the_segment_point_distance);
    RUN_TEST(test_cylinder_on_a_tilted_flank_is_its_least_ball);
    RUN_TEST(test_cylinder_parallel_to_the_tip_axis_touches_at_its_top_end);
    RUN_TEST(test_cylinder_along_a_generator_has_the_flat_gap);
    RUN_TEST(test_zero_length_cylinder_is_a_sphere_and_on_axis_centres_stay_finite);
    RUN_TEST(test_half_angle_at_and_near_0_and_90_deg_stays_well_conditioned);
    RUN_TEST(test_out_of_range_arguments_are_refused_naming_the_value);
    RUN_TEST(test_planes_touch_the_apex_with_their_normal);
    RUN_TEST(test_trench_edge_is_touched_by_the_flank);
    RUN_TEST(test_rough_substrate_contact_has_its_surface_normal);
    RUN_TEST(test_rod_on_the_flank_has_the_closed_form_depth_and_normal);
    RUN_TEST(test_rod_under_the_apex_and_a_flat_cone_stay_well_conditioned);
    RUN_TEST(test_rod_lift_off_push_matches_the_hand_derived_balance);
    RUN_TEST(test_rod_lift_off_hard_cases);
    return UNITY_END();
}
