// Unity tests of the scene-to-card table (host/card/card_table.hpp) and the
// card's refusal (card_setup.hpp): settings converted as computed by hand
// here (units, Q formats, the calibrations and defaults chosen); the card
// reads nothing of the scene's probe and sample (the truth): its section,
// a bench calibration or its nominal, each named in card_sources; every
// setting of the board but its two optional ones comes from a row; each
// rule's keys, in order, named once; and a refusal's line, from a scene file.
#include "card_setup.hpp"
#include "card_table.hpp"

extern "C" {
#include "fw_marshal.h"
}

#include <unity.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

using afm::SceneKeys;

namespace {

// A scene with round values: each setting below is computed by hand from them.
afm::Scene hand_scene()
{
    afm::Scene s;
    s.fw_cal.spring_N_per_m = 0.2;
    s.fw_cal.deflection_nm_per_V = 50;
    s.fw_cal.lateral_nN_per_V = 30;
    s.fw_cal.tip_height_um = 10;
    s.fw_cal.lever_length_um = 200;
    s.probe.scan_angle_deg = 270;
    s.fw_cal.tip_radius_nm = 12.5;
    s.fw_cal.mu = 0.0865;
    s.fw_cal.adhesion_nN = 3;
    s.field_nm = 2000;
    s.field_center_nm = {100, -250};
    s.op.kappa = 1.5;
    s.fw_cal.litho_depth_nm_per_nN = 0.25;
    s.op.haptic.force_gain_N_per_nN = 0.004;
    s.op.haptic.max_force_N = 3;
    s.adc_bits = 12;
    s.word_bits = 32;
    s.effects = {"bending_offset"};   // no adhesion
    return s;
}

fw_card_config_t filled(const afm::Scene &s)
{
    fw_card_config_t c;
    std::memset(&c, 0x5a, sizeof c);
    afm::fill_card_rows(s, &c);
    return c;
}

void expect_keys(const SceneKeys &want, const SceneKeys &got)
{
    TEST_ASSERT_EQUAL_INT(static_cast<int>(want.size()), static_cast<int>(got.size()));
    for (std::size_t i = 0; i < want.size(); ++i) {
        TEST_ASSERT_EQUAL_STRING(want[i].first.c_str(), got[i].first.c_str());
        TEST_ASSERT_EQUAL_DOUBLE(want[i].second, got[i].second);
    }
}

}  // namespace

void setUp() {}
void tearDown() {}

// The card section's values in the firmware's units.
void test_rows_convert_the_scene_as_computed_by_hand()
{
    const fw_card_config_t c = filled(hand_scene());
    TEST_ASSERT_EQUAL_INT32(12, c.board.adc_bits);
    TEST_ASSERT_EQUAL_INT32(32, c.word_bits);
    TEST_ASSERT_EQUAL_INT32(10000, c.board.normal_gain_pn_per_v);   // 0.2 N/m x 50 nm/V = 10 nN/V
    TEST_ASSERT_EQUAL_INT32(30000, c.board.lateral_gain_pn_per_v);
    TEST_ASSERT_EQUAL_INT32(50000, c.board.deflection_pm_per_v);
    TEST_ASSERT_EQUAL_INT32(10000, c.board.tip_height_nm);
    TEST_ASSERT_EQUAL_INT32(200000, c.board.lever_length_nm);
    TEST_ASSERT_EQUAL_INT32(FW_CARD_DISP_ESTIMATE, c.board.disp_n_pm_per_v);
    TEST_ASSERT_EQUAL_INT32(FW_CARD_DISP_ESTIMATE, c.board.disp_l_pm_per_v);
    TEST_ASSERT_EQUAL_INT32(270000, c.board.scan_angle_mdeg);
    TEST_ASSERT_EQUAL_INT32(86500, c.board.mu_ppm);
    TEST_ASSERT_EQUAL_INT32(0, c.board.adhesion_pn);   // the adhesion effect is off
    TEST_ASSERT_EQUAL_INT32(100000, c.board.scan_center_pm[0]);
    TEST_ASSERT_EQUAL_INT32(-250000, c.board.scan_center_pm[1]);
    TEST_ASSERT_EQUAL_INT32(1000000, c.board.scan_half_range_pm);
    TEST_ASSERT_EQUAL_INT32(98304, c.board.kappa_q16);       // 1.5 in 16.16
    TEST_ASSERT_EQUAL_INT32(16384, c.litho_depth_pm_per_pn);  // 0.25 nm/nN = pm/pN, 16.16
    TEST_ASSERT_EQUAL_INT32(12500, c.tip_radius_pm);
    TEST_ASSERT_EQUAL_INT32(1000000, c.landmark_max_step_pm);
    TEST_ASSERT_EQUAL_INT32(0, c.drift_max_step_pm);          // the firmware's default
    TEST_ASSERT_EQUAL_INT32(4, c.haptic_un_per_pn);           // 0.004 N/nN = 4 uN/pN
    TEST_ASSERT_EQUAL_INT32(3000000, c.haptic_max_un);
    // 80 % of each channel's full scale, gain x 10 V
    TEST_ASSERT_EQUAL_INT32(80000, c.interlock_normal_pn);
    TEST_ASSERT_EQUAL_INT32(240000, c.interlock_lateral_pn);
}

// firmware.* where the scene gives it; the effects and compensate as the card reads them.
void test_calibrations_and_effects_take_their_rows()
{
    afm::Scene s = hand_scene();
    s.fw_cal.lateral_nN_per_V.reset();
    s.fw_cal.mu.reset();
    s.fw_cal.lateral_nN_per_V = 40;
    s.fw_cal.mu = 0.25;
    s.fw_cal.disp_n_nm_per_V = 75;
    s.fw_cal.drift_max_step_nm = 300;
    s.fw_cal.interlock_normal_nN = 55;
    s.effects.push_back("adhesion");
    fw_card_config_t c = filled(s);
    TEST_ASSERT_EQUAL_INT32(40000, c.board.lateral_gain_pn_per_v);
    TEST_ASSERT_EQUAL_INT32(250000, c.board.mu_ppm);
    TEST_ASSERT_EQUAL_INT32(75000, c.board.disp_n_pm_per_v);
    TEST_ASSERT_EQUAL_INT32(FW_CARD_DISP_ESTIMATE, c.board.disp_l_pm_per_v);
    TEST_ASSERT_EQUAL_INT32(300000, c.drift_max_step_pm);
    TEST_ASSERT_EQUAL_INT32(55000, c.interlock_normal_pn);
    TEST_ASSERT_EQUAL_INT32(320000, c.interlock_lateral_pn);   // 80 % of 40 nN/V x 10 V
    TEST_ASSERT_EQUAL_INT32(3000, c.board.adhesion_pn);
    s.compensate = false;
    c = filled(s);
    TEST_ASSERT_EQUAL_INT32(0, c.board.disp_n_pm_per_v);
    TEST_ASSERT_EQUAL_INT32(0, c.board.disp_l_pm_per_v);
}

// The truth (the probe and sample sections) changes nothing the card is
// given: each of its values is the card section's, a calibration's or a nominal.
void test_the_card_reads_nothing_of_the_truth()
{
    afm::Scene a, b;
    b.probe.spring_N_per_m = 0.3;
    b.probe.deflection_nm_per_V = 60;
    b.probe.lateral_nN_per_V = 20;
    b.probe.lever_length_um = 150;
    b.probe.tip_height_um = 9;
    b.probe.tip_radius_nm = 30;
    b.probe.tip_half_angle_deg = 50;
    b.tip_substrate = {0.4, 7, 0, 0};
    b.particle_substrate = {0.6, 9, 5, 100};
    b.wire_model.friction_nN_per_um = 70;
    b.wire_model.mu = 0.9;
    b.litho = {5, 0.5};
    for (afm::Scene *s : {&a, &b}) s->effects = {"adhesion"};
    const fw_card_config_t ca = filled(a), cb = filled(b);
    TEST_ASSERT_EQUAL_MEMORY(&ca, &cb, sizeof ca);
    TEST_ASSERT_EQUAL_INT32(22000, ca.tip_half_angle_mdeg);   // the nominal, not the truth's 20 deg
    TEST_ASSERT_EQUAL_INT32(100000, ca.board.mu_ppm);         // nominal 0.1, not the truth's 0.0865
    for (const auto &c : afm::card_sources(b)) {
        TEST_ASSERT_TRUE_MESSAGE(c.key.rfind("probe.", 0) != 0 || c.key == "probe.scan_angle_deg", c.key.c_str());
        TEST_ASSERT_TRUE_MESSAGE(c.key.rfind("sample.", 0) != 0 || c.key.rfind("sample.field", 0) == 0, c.key.c_str());
    }
}

// Each constant's source: the card section, a bench calibration, a nominal.
void test_card_sources_name_section_calibration_and_nominal()
{
    afm::Scene s;
    s.fw_cal.tip_half_angle_deg = 50;
    s.fw_cal.calibration = afm::FirmwareCalibration::Bench{"tilted fnv1a64:0123456789abcdef", 0.09, 36.5, std::nullopt};
    const fw_card_config_t c = filled(s);
    TEST_ASSERT_EQUAL_INT32(90000, c.board.mu_ppm);
    TEST_ASSERT_EQUAL_INT32(36500, c.board.lateral_gain_pn_per_v);
    TEST_ASSERT_EQUAL_INT32(50000, c.tip_half_angle_mdeg);
    auto source = [&](const std::string &field) {
        for (const auto &x : afm::card_sources(s))
            if (x.field == field) return x.key + " = " + std::to_string(x.value) + ": " + x.source;
        return std::string("none");
    };
    TEST_ASSERT_EQUAL_STRING("firmware.calibration.mu = 0.090000: calibration run tilted fnv1a64:0123456789abcdef",
                             source("board.mu_ppm").c_str());
    TEST_ASSERT_EQUAL_STRING("firmware.tip_half_angle_deg = 50.000000: scene card section", source("tip_half_angle_mdeg").c_str());
    TEST_ASSERT_EQUAL_STRING("firmware.wire_mu (nominal) = 0.300000: nominal", source("wire_mu_ppm").c_str());
    TEST_ASSERT_EQUAL_STRING("operator.kappa = 1.000000: scene configuration", source("board.kappa_q16").c_str());
    s.fw_cal.mu = 0.2;   // the card section wins over the calibration
    TEST_ASSERT_EQUAL_STRING("firmware.mu = 0.200000: scene card section", source("board.mu_ppm").c_str());
}

// Every setting of the board comes from a row, but the two optional ones
// (0: the firmware's default), which no scene key sets.
void test_every_board_setting_but_the_optional_ones_has_a_row()
{
    const fw_card_config_t c = filled(hand_scene());
    const int32_t untouched = 0x5a5a5a5a;
    TEST_ASSERT_EQUAL_INT32(untouched, c.board.filter_log2);
    TEST_ASSERT_EQUAL_INT32(untouched, c.board.theta_min_disp_pm);
    const int32_t *b = reinterpret_cast<const int32_t *>(&c.board);
    const std::size_t n = offsetof(fw_board_config_t, filter_log2) / sizeof(int32_t);
    for (std::size_t i = 0; i < n; ++i) TEST_ASSERT_NOT_EQUAL_MESSAGE(untouched, b[i], "a board setting no row fills");
    for (const afm::CardRow &r : afm::card_rows()) TEST_ASSERT_NOT_NULL(r.field);
}

// A rule's keys: every row feeding it, in the table's order, each key once.
void test_a_rules_keys_are_its_rows_keys_in_order()
{
    afm::Scene s = hand_scene();
    s.fw_cal.lateral_nN_per_V.reset();
    s.fw_cal.mu.reset();
    expect_keys({{"firmware.word_bits", 32}, {"firmware.spring_N_per_m", 0.2}, {"firmware.deflection_nm_per_V", 50},
                 {"firmware.lateral_nN_per_V (nominal)", 37.9}, {"firmware.tip_height_um", 10}, {"firmware.lever_length_um", 200}},
                afm::card_rule_keys(s, FW_RULE_WORD16_RANGE));
    expect_keys({{"firmware.tip_height_um", 10}, {"firmware.deflection_nm_per_V", 50}, {"firmware.lever_length_um", 200}},
                afm::card_rule_keys(s, FW_RULE_DISP_RANGE));
    expect_keys({{"firmware.interlock_normal_nN", -1}, {"firmware.spring_N_per_m", 0.2}, {"firmware.deflection_nm_per_V", 50}},
                afm::card_rule_keys(s, FW_RULE_INTERLOCK_NORMAL));
    expect_keys({{"sample.field_nm", 2000}, {"operator.kappa", 1.5}}, afm::card_rule_keys(s, FW_RULE_JOYSTICK_RANGE));
    expect_keys({{"sample.field_nm", 2000}}, afm::card_rule_keys(s, FW_RULE_DRIFT_STEP));
    // calibrated: the keys the card's values came from
    s.fw_cal.mu = 0.25;
    s.fw_cal.lateral_nN_per_V = 40;
    s.fw_cal.disp_n_nm_per_V = 75;
    s.fw_cal.disp_l_nm_per_V = 80;
    expect_keys({{"firmware.mu", 0.25}, {"firmware.tip_height_um", 10}, {"firmware.lever_length_um", 200}},
                afm::card_rule_keys(s, FW_RULE_MU_2H_OVER_L));
    expect_keys({{"firmware.spring_N_per_m", 0.2}, {"firmware.deflection_nm_per_V", 50}, {"firmware.lateral_nN_per_V", 40}},
                afm::card_rule_keys(s, FW_RULE_FORCE_GAINS));
    expect_keys({{"firmware.disp_n_nm_per_V", 75}, {"firmware.disp_l_nm_per_V", 80}}, afm::card_rule_keys(s, FW_RULE_DISP_NEGATIVE));
    // rules about what no scalar setting holds (the lists, the storage)
    for (fw_rule_t r : {FW_RULE_OK, FW_RULE_NULL_POINTER, FW_RULE_PARTICLE_CAPACITY, FW_RULE_LANDMARKS, FW_RULE_TILTED_SLOPE})
        TEST_ASSERT_EQUAL_INT(0, static_cast<int>(afm::card_rule_keys(s, r).size()));
}

// The refusal's line: the first key names it, the rule in the firmware's words, every key with its value.
void test_a_refusal_names_the_rule_and_its_keys()
{
    afm::Scene s = afm::load_scene(std::string(AFM_SOURCE_DIR) + "/scenes/default.yaml");
    TEST_ASSERT_EQUAL_STRING("", afm::card_refusal(s).c_str());
    s.fw_cal.tip_height_um = 100;   // the lever's nominal length
    const std::string why = afm::card_refusal(s);
    const std::string want = std::string("firmware.tip_height_um: the firmware's card refuses it: ") + fw_rule_text(FW_RULE_TIP_SHORTER_THAN_LEVER);
    TEST_ASSERT_EQUAL_STRING(want.c_str(), why.substr(0, want.size()).c_str());
    TEST_ASSERT_TRUE(why.find("(fw_card_init: FW_ERR_DOMAIN, rule " + std::to_string(FW_RULE_TIP_SHORTER_THAN_LEVER) + ")") != std::string::npos);
    TEST_ASSERT_TRUE(why.find("; got firmware.tip_height_um ") != std::string::npos);
    TEST_ASSERT_TRUE(why.find(", firmware.lever_length_um (nominal) ") != std::string::npos);
}

// A scene with the scanner's compensation on: a two-play model per axis
// (./afm calib scanner's firmware.scanner), the creep law's gamma given, t0
// the nominal.
afm::Scene scanner_scene()
{
    afm::Scene s = hand_scene();
    s.op.path_nm = {{-400, 300}, {0, 0}};
    s.block_hz = 500;
    s.fw_cal.hyst_enable = s.fw_cal.creep_enable = true;
    s.fw_cal.creep_gamma_pct_per_decade = 1.5;
    afm::FirmwareCalibration::Scanner sc;
    sc.run = "scanner sha256:0123456789abcdef";
    sc.axis[0] = {{0, 500}, {0.8, 0.3}};
    sc.axis[1] = {{0, 250.5}, {0.9, 0.1}};
    s.fw_cal.scanner = sc;
    return s;
}

// The compensation's rows: the switches, each axis's model about the path's
// start over the field from there, the creep law; off, the rows name no key
// and fill nothing.
void test_scanner_compensation_rows()
{
    const afm::Scene s = scanner_scene();
    fw_card_config_t c = filled(s);
    TEST_ASSERT_TRUE(c.hyst_enable);
    TEST_ASSERT_TRUE(c.creep_enable);
    TEST_ASSERT_EQUAL_INT32(2, c.hyst[0].n);
    TEST_ASSERT_EQUAL_INT32(500000, c.hyst[0].r_pm[1]);
    TEST_ASSERT_EQUAL_INT32(250500, c.hyst[1].r_pm[1]);
    TEST_ASSERT_EQUAL_INT32(13421773, c.hyst[0].w_q24[0]);   // 0.8 2^24
    TEST_ASSERT_EQUAL_INT32(1677722, c.hyst[1].w_q24[1]);    // 0.1 2^24
    TEST_ASSERT_EQUAL_INT32(-400000, c.hyst[0].origin_pm);
    TEST_ASSERT_EQUAL_INT32(300000, c.hyst[1].origin_pm);
    TEST_ASSERT_EQUAL_INT32(500000 + 1200000, c.hyst[0].range_pm);   // |start - centre| + 0.6 field
    TEST_ASSERT_EQUAL_INT32(550000 + 1200000, c.hyst[1].range_pm);
    TEST_ASSERT_EQUAL_INT32(15000, c.creep.gamma_ppm);
    TEST_ASSERT_EQUAL_INT32(100000, c.creep.t0_us);
    TEST_ASSERT_EQUAL_INT32(2000, c.creep.period_us);
    auto source = [&](const std::string &key) {
        for (const auto &x : afm::card_sources(s))
            if (x.key == key) return x.field + " = " + std::to_string(x.value) + ": " + x.source;
        return std::string("none");
    };
    TEST_ASSERT_EQUAL_STRING("hyst[0] = 500.000000: calibration run scanner sha256:0123456789abcdef", source("firmware.scanner.x.r_nm[1]").c_str());
    TEST_ASSERT_EQUAL_STRING("hyst[1] = 0.100000: calibration run scanner sha256:0123456789abcdef", source("firmware.scanner.y.w[1]").c_str());
    TEST_ASSERT_EQUAL_STRING("creep = 1.500000: scene card section", source("firmware.creep_gamma_pct_per_decade").c_str());
    TEST_ASSERT_EQUAL_STRING("creep = 0.100000: nominal", source("firmware.creep_t0_s (nominal)").c_str());
    TEST_ASSERT_EQUAL_STRING("hyst_enable = 1.000000: scene card section", source("firmware.hyst_enable").c_str());
    expect_keys({{"firmware.creep_enable", 1}, {"firmware.creep_gamma_pct_per_decade", 1.5}, {"firmware.creep_t0_s (nominal)", 0.1},
                 {"block_hz", 500}},
                afm::card_rule_keys(s, FW_RULE_CREEP));
    TEST_ASSERT_EQUAL_STRING("firmware.hyst_enable", afm::card_rule_keys(s, FW_RULE_HYST).front().first.c_str());
    // off: no key, nothing filled (the zeroed configuration runs the card as without it)
    afm::Scene off = s;
    off.fw_cal.hyst_enable = off.fw_cal.creep_enable = false;
    c = filled(off);
    TEST_ASSERT_FALSE(c.hyst_enable);
    TEST_ASSERT_EQUAL_INT32(0x5a5a5a5a, c.hyst[0].n);
    TEST_ASSERT_EQUAL_INT32(0x5a5a5a5a, c.creep.gamma_ppm);
    expect_keys({{"firmware.creep_enable", 0}}, afm::card_rule_keys(off, FW_RULE_CREEP));
    expect_keys({{"firmware.hyst_enable", 0}}, afm::card_rule_keys(off, FW_RULE_HYST));
    TEST_ASSERT_EQUAL_STRING("", afm::card_refusal(s).c_str());
}

// The card's INIT message (fw_marshal, what the board is given) for two
// scenes whose scanner truth differs (afm.hysteresis, afm.creep) and whose
// firmware section is the same: the same bytes.
void test_the_scanner_truth_reaches_no_init()
{
    afm::Scene a = scanner_scene(), b = scanner_scene();
    for (afm::Scene *s : {&a, &b}) s->effects = {"piezo_hysteresis", "piezo_creep"};
    b.instrument.hysteresis_width_pct = 25;
    b.instrument.hysteresis_span_nm = 900;
    b.instrument.creep_pct_per_decade = 4;
    b.instrument.creep_t0_s = 0.5;
    auto init = [](const afm::Scene &s) {
        const afm::CardSetup setup(s);
        std::string buf(1 << 16, '\0');
        fw_marshal_cursor_t cur;
        fw_marshal_writer_init(&cur, reinterpret_cast<uint8_t *>(&buf[0]), static_cast<uint32_t>(buf.size()));
        fw_marshal_put_config_le(&cur, &setup.config(), &setup.storage());
        TEST_ASSERT_TRUE(fw_marshal_ok(&cur));
        return buf;
    };
    TEST_ASSERT_TRUE(init(a) == init(b));
    b.fw_cal.scanner->axis[0].w[1] = 0.31;   // the card section's change does reach it
    TEST_ASSERT_FALSE(init(a) == init(b));
}

// A model the card cannot invert (a partial sum of its weights past 2,
// given past the reader): refused by the card's rule, the line named by the
// switch with the model's keys.
void test_a_scanner_model_the_card_cannot_invert_is_refused()
{
    afm::Scene s = scanner_scene();
    s.fw_cal.scanner->axis[1].w = {0.9, 1.2};
    const std::string why = afm::card_refusal(s);
    const std::string want = std::string("firmware.hyst_enable: the firmware's card refuses it: ") + fw_rule_text(FW_RULE_HYST);
    TEST_ASSERT_EQUAL_STRING(want.c_str(), why.substr(0, want.size()).c_str());
    TEST_ASSERT_TRUE(why.find("firmware.scanner.y.w[1] 1.2") != std::string::npos);
    s = scanner_scene();
    s.fw_cal.creep_t0_s = 0.01;   // the block's period 2 ms past t0 / 16
    TEST_ASSERT_EQUAL_STRING("firmware.creep_enable", afm::card_rule_keys(s, FW_RULE_CREEP).front().first.c_str());
    TEST_ASSERT_TRUE(afm::card_refusal(s).find(fw_rule_text(FW_RULE_CREEP)) != std::string::npos);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_rows_convert_the_scene_as_computed_by_hand);
    RUN_TEST(test_calibrations_and_effects_take_their_rows);
    RUN_TEST(test_the_card_reads_nothing_of_the_truth);
    RUN_TEST(test_card_sources_name_section_calibration_and_nominal);
    RUN_TEST(test_every_board_setting_but_the_optional_ones_has_a_row);
    RUN_TEST(test_a_rules_keys_are_its_rows_keys_in_order);
    RUN_TEST(test_a_refusal_names_the_rule_and_its_keys);
    RUN_TEST(test_scanner_compensation_rows);
    RUN_TEST(test_the_scanner_truth_reaches_no_init);
    RUN_TEST(test_a_scanner_model_the_card_cannot_invert_is_refused);
    return UNITY_END();
}
