// Unity tests of the wires in a scene (sim_afm/wire.*, scene/): which wire
// model a scene builds, the load-dependent friction (eq. 23-24, a Hertz line
// contact), the load ramp. The rod and the flexible wire have files of their
// own (test_rods.cpp, test_rod_solver.cpp, test_flexible_wires.cpp).
#include <unity.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "wire_fixtures.hpp"

using afm::sim::World;

void setUp() {}
void tearDown() {}

void test_scenes_build_only_the_wire_model_they_need()
{
    // No wire in the scene: no wire model, even with wire_flexibility listed.
    std::string text = with(with(with(with(with(with(with(kWireScene, "SOLVER", "closed_form"), "LOAD", "5"), "GAMMA", "20"), "SWEEPS", "8"), "EXTRA", ", wire_flexibility"), "FRICTION", "20"), "SEGMENTS", "32");
    text = with(text, "objects:\n  wires:\n    - {id: 4, x0_nm: -HALF, y0_nm: 0, x1_nm: HALF, y1_nm: 0, diameter_nm: 100}\n", "");
    const afm::Scene none = scene_from_text(text);
    World a(none);
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(a.wires().size()));
    for (const auto &m : a.models_built()) TEST_ASSERT_TRUE_MESSAGE(m.find("wires") == std::string::npos, m.c_str());
    // Wires without wire_flexibility: rigid rods; with it: chains.
    World b(wire_scene(1000));
    TEST_ASSERT_TRUE(has(b.models_built(), "wires:rigid_rod"));
    World c(wire_scene(1000, ", wire_flexibility"));
    TEST_ASSERT_TRUE(has(c.models_built(), "wires:flexible_chain"));
    TEST_ASSERT_EQUAL_INT(33, static_cast<int>(c.wires()[0]->nodes().size()));
}

void test_load_dependent_friction_is_eq_23_24_with_a_hertz_line_contact()
{
    // f = mu_os F_a,os / L + tau_os A / L; A / L = 2 b, Hertz's line contact
    // b = sqrt(4 P' R / (pi E*)): silver (83 GPa, 0.37) on glass (70 GPa,
    // 0.22), P' = 20 nN/um = 0.02 N/m, R = 50 nm, computed here by hand.
    const std::string base = with(kWireScene, "friction_nN_per_um: FRICTION", "mu: 0.2, adhesion_nN_per_um: 20, shear_strength_MPa: 10");
    const afm::Scene s = scene_from_text(filled(base));
    const double Estar = 1.0 / ((1 - 0.37 * 0.37) / 83e9 + (1 - 0.22 * 0.22) / 70e9);
    const double b_nm = std::sqrt(4 * 0.02 * 50e-9 / (M_PI * Estar)) * 1e9;
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 2 * b_nm, s.wire_contact_width_nm());
    TEST_ASSERT_DOUBLE_WITHIN(1e-9, 0.2 * 20 + 10 * 2 * b_nm, s.wire_friction_nN_per_um());
    std::printf("Hertz line contact: width %.3f nm; f = %.3f nN/um (mu F_a %.1f + tau A %.3f)\n", 2 * b_nm,
                s.wire_friction_nN_per_um(), 0.2 * 20, 10 * 2 * b_nm);
    // contact: none drops tau A; without adhesion_nN_per_um f is the given one.
    const afm::Scene n = scene_from_text(filled(with(base, "shear_strength_MPa: 10", "shear_strength_MPa: 10, contact: none")));
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 4.0, n.wire_friction_nN_per_um());
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 20.0, wire_scene(1300).wire_friction_nN_per_um());
    // The adhesion acts with the adhesion effect alone (issue 47: no physics
    // the scene did not ask for): without it no load, no width, no friction.
    const afm::Scene off = scene_from_text(with(filled(base), "effects: [bending_offset, adhesion", "effects: [bending_offset"));
    TEST_ASSERT_FALSE(off.has_effect("adhesion"));
    TEST_ASSERT_EQUAL_DOUBLE(0.0, off.wire_adhesion_nN_per_um());
    TEST_ASSERT_EQUAL_DOUBLE(0.0, off.wire_contact_width_nm());
    TEST_ASSERT_EQUAL_DOUBLE(0.0, off.wire_friction_nN_per_um());
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 20.0, s.wire_adhesion_nN_per_um());
    // Both f and the adhesion, or tau without the adhesion: refused, named.
    const std::string both = filled(with(kWireScene, "friction_nN_per_um: FRICTION", "friction_nN_per_um: 3, adhesion_nN_per_um: 20"));
    TEST_ASSERT_TRUE(scene_error(both).find("sample.wire.friction_nN_per_um") != std::string::npos);
    const std::string lone = filled(with(kWireScene, "friction_nN_per_um: FRICTION", "friction_nN_per_um: 3, shear_strength_MPa: 1"));
    TEST_ASSERT_TRUE(scene_error(lone).find("sample.wire.shear_strength_MPa") != std::string::npos);
}

void test_a_load_ramp_rises_linearly_over_the_run()
{
    afm::Scene s = wire_scene(1300);
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 5.0, s.load_at_nN(0.5));   // no ramp: constant
    s.op.load_ramp_to_nN = 9.0;
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 5.0, s.load_at_nN(0.0));
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 7.0, s.load_at_nN(0.5 * s.duration_s));
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 9.0, s.load_at_nN(10 * s.duration_s));   // held past the end
    TEST_ASSERT_DOUBLE_WITHIN(1e-12, 5.0, s.load_at_nN(-1.0));
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_scenes_build_only_the_wire_model_they_need);
    RUN_TEST(test_load_dependent_friction_is_eq_23_24_with_a_hertz_line_contact);
    RUN_TEST(test_a_load_ramp_rises_linearly_over_the_run);
    return UNITY_END();
}
