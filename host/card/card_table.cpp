#include "card_table.hpp"

extern "C" {
#include "fw_calib.h"
#include "fw_guard.h"
#include "fw_units.h"
}

#include <algorithm>
#include <cmath>
#include <optional>

#include "haptic_bound.hpp"

namespace afm {

namespace {

// The card's nominal values: what a lab holds before it measures anything
// (the paper's lever's datasheet, fw_paper_probe.h; the tip's catalogue
// figures; the paper's materials). A row takes its nominal only when the
// scene's firmware.* gives nothing and no bench calibration measured it; it
// is never the scene's probe or sample (the simulator's truth). Their
// offsets from the default truth are deliberate and listed in
// docs/scenes.md ("### firmware"): the half angle's 2 deg, mu's 0.0135.
struct Nominal {
    double spring_N_per_m = FW_PAPER_KN_MN_PER_M * 1e-3;
    double deflection_nm_per_V = FW_PAPER_DEFLECTION_PM_PER_V * 1e-3;
    double lateral_nN_per_V = FW_PAPER_LATERAL_GAIN_PN_PER_V * 1e-3;
    double lever_length_um = FW_PAPER_LEVER_LENGTH_NM * 1e-3;
    double tip_height_um = FW_PAPER_TIP_HEIGHT_NM * 1e-3;
    double tip_radius_nm = 10.0;
    double tip_half_angle_deg = 22.0;   // the catalogue's "< 22 deg"; the default truth's is 20
    double mu = 0.1;                    // a silicon nitride tip on glass, before calibration; the paper calibrated 0.0865
    double adhesion_nN = 1.0;
    double particle_mu = 0.3, particle_adhesion_nN = 3.0, particle_shear_strength_MPa = 0, particle_contact_area_nm2 = 0;
    double wire_friction_nN_per_um = 20.0, wire_mu = 0.3;
    double litho_threshold_nN = 20.0, litho_depth_nm_per_nN = 2.0;
    double creep_gamma_pct_per_decade = 1.0, creep_t0_s = 0.1;   // a piezo tube's catalogue: 1-2 % a decade
    // the drift filter's figures: issue 48's lab drift (50 nm/min, a walk of
    // 10 nm/sqrt(min)) with the rate's prior at twice it; a local scan's
    // registration to half a nanometre (test_drift: its fixes within 1 nm)
    double drift_walk_nm_per_sqrt_min = 10.0, drift_rate_nm_per_min = 100.0, drift_scan_sigma_nm = 0.5;
};
const Nominal kNominal;

constexpr const char *kNominalSuffix = " (nominal)";
constexpr const char *kCalibrationPrefix = "firmware.calibration.";

// One constant as the card has it: the scene's firmware.* (its card
// section), else a bench calibration's result (firmware.calibration.*),
// else the nominal, named with its key.
std::pair<std::string, double> card_value(const std::string &name, const std::optional<double> &given,
                                          const std::optional<double> &calibrated, double nominal)
{
    if (given) return {"firmware." + name, *given};
    if (calibrated) return {kCalibrationPrefix + name, *calibrated};
    return {"firmware." + name + kNominalSuffix, nominal};
}
std::pair<std::string, double> card_value(const std::string &name, const std::optional<double> &given, double nominal)
{
    return card_value(name, given, std::nullopt, nominal);
}
std::optional<double> calibrated(const Scene &s, std::optional<double> FirmwareCalibration::Bench::*field)
{
    return s.fw_cal.calibration ? (*s.fw_cal.calibration).*field : std::nullopt;
}

using K = std::pair<std::string, double>;
K spring(const Scene &s) { return card_value("spring_N_per_m", s.fw_cal.spring_N_per_m, kNominal.spring_N_per_m); }
K deflection(const Scene &s) { return card_value("deflection_nm_per_V", s.fw_cal.deflection_nm_per_V, kNominal.deflection_nm_per_V); }
K lever_length(const Scene &s) { return card_value("lever_length_um", s.fw_cal.lever_length_um, kNominal.lever_length_um); }
K tip_height(const Scene &s) { return card_value("tip_height_um", s.fw_cal.tip_height_um, kNominal.tip_height_um); }
K lateral(const Scene &s)
{
    return card_value("lateral_nN_per_V", s.fw_cal.lateral_nN_per_V, calibrated(s, &FirmwareCalibration::Bench::lateral_nN_per_V),
                      kNominal.lateral_nN_per_V);
}
K tip_mu(const Scene &s)
{
    return card_value("mu", s.fw_cal.mu, calibrated(s, &FirmwareCalibration::Bench::mu), kNominal.mu);
}
std::optional<double> disp_n(const Scene &s)
{
    return s.fw_cal.disp_n_nm_per_V ? s.fw_cal.disp_n_nm_per_V : calibrated(s, &FirmwareCalibration::Bench::disp_n_nm_per_V);
}

// k_n K_n and k_theta K_l / h, pN/V (the interlock's default limits read them too).
int32_t normal_gain_pn_per_v(const Scene &s)
{
    return fwu_pn_per_v_from_nn_per_v(spring(s).second * deflection(s).second);   // N/m nm/V = nN/V
}
int32_t lateral_gain_pn_per_v(const Scene &s)
{
    return fwu_pn_per_v_from_nn_per_v(lateral(s).second);
}
// C_n or C_l: calibrated, or the firmware's estimate from the card's h, K_n and l.
SceneKeys disp_keys(const char *name, const std::optional<double> &given, const std::optional<double> &cal, const Scene &s)
{
    if (given || cal) return {card_value(name, given, cal, 0)};
    return {tip_height(s), deflection(s), lever_length(s)};
}
int32_t disp_pm_per_v(const std::optional<double> &cal, const Scene &s)
{
    if (!s.compensate) return 0;   // firmware.compensate: false: the piezo is taken as the apex
    return cal ? fwu_pm_per_v_from_nm_per_v(*cal) : FW_CARD_DISP_ESTIMATE;
}
// The card's adhesion acts where the run lists the adhesion effect (the
// lab's choice of environment, as the effect is the scene's).
double adhesion_if_on(const Scene &s, double nN)
{
    return s.has_effect("adhesion") ? nN : 0.0;
}
K tip_adhesion(const Scene &s) { return card_value("adhesion_nN", s.fw_cal.adhesion_nN, kNominal.adhesion_nN); }
K tip_radius(const Scene &s) { return card_value("tip_radius_nm", s.fw_cal.tip_radius_nm, kNominal.tip_radius_nm); }
K half_angle(const Scene &s) { return card_value("tip_half_angle_deg", s.fw_cal.tip_half_angle_deg, kNominal.tip_half_angle_deg); }
K particle_mu(const Scene &s) { return card_value("particle_mu", s.fw_cal.particle_mu, kNominal.particle_mu); }
K particle_adhesion(const Scene &s)
{
    return card_value("particle_adhesion_nN", s.fw_cal.particle_adhesion_nN, kNominal.particle_adhesion_nN);
}
K particle_shear(const Scene &s)
{
    return card_value("particle_shear_strength_MPa", s.fw_cal.particle_shear_strength_MPa, kNominal.particle_shear_strength_MPa);
}
K particle_area(const Scene &s)
{
    return card_value("particle_contact_area_nm2", s.fw_cal.particle_contact_area_nm2, kNominal.particle_contact_area_nm2);
}
K wire_friction(const Scene &s)
{
    return card_value("wire_friction_nN_per_um", s.fw_cal.wire_friction_nN_per_um, kNominal.wire_friction_nN_per_um);
}
K wire_mu(const Scene &s) { return card_value("wire_mu", s.fw_cal.wire_mu, kNominal.wire_mu); }
K litho_threshold(const Scene &s) { return card_value("litho_threshold_nN", s.fw_cal.litho_threshold_nN, kNominal.litho_threshold_nN); }
K litho_depth(const Scene &s)
{
    return card_value("litho_depth_nm_per_nN", s.fw_cal.litho_depth_nm_per_nN, kNominal.litho_depth_nm_per_nN);
}

// The scanner's compensation (fw_card.h: creep_enable, hyst_enable). Off,
// its rows name no key and leave the configuration zeroed (the card as
// without it, bit for bit). The creep law: the scene's firmware.creep_*
// (a datasheet's or a lab's step test), else the nominal; the block's
// period from the run's block_hz. The hysteresis: each axis's direct model
// as ./afm calib scanner fitted it (firmware.scanner, source "calibration
// run ID"), about the scanner's rest at block 0 (the path's first point:
// every play 0 there, as a scanner at rest after its last cycle), over the
// field from there with a tenth of the field to spare.
K creep_gamma(const Scene &s)
{
    return card_value("creep_gamma_pct_per_decade", s.fw_cal.creep_gamma_pct_per_decade, kNominal.creep_gamma_pct_per_decade);
}
K creep_t0(const Scene &s) { return card_value("creep_t0_s", s.fw_cal.creep_t0_s, kNominal.creep_t0_s); }
SceneKeys creep_keys(const Scene &s)
{
    if (!s.fw_cal.creep_enable) return {};
    return {creep_gamma(s), creep_t0(s), {"block_hz", s.block_hz}};
}
void fill_creep(const Scene &s, fw_card_config_t *c)
{
    if (!s.fw_cal.creep_enable) return;
    c->creep.gamma_ppm = fwu_i32(creep_gamma(s).second * 1e4);   // % -> ppm
    c->creep.t0_us = fwu_i32(creep_t0(s).second * 1e6);
    c->creep.period_us = fwu_i32(1e6 / s.block_hz);
}
// The drift estimate (fw_drift.h): the step filter names no key beyond
// its switch; the Kalman filter its figures (the scene's firmware.drift_*,
// else the nominal) and the block's period from block_hz.
bool kalman(const Scene &s) { return s.fw_cal.drift_filter == "kalman"; }
K drift_walk(const Scene &s) { return card_value("drift_walk_nm_per_sqrt_min", s.fw_cal.drift_walk_nm_per_sqrt_min, kNominal.drift_walk_nm_per_sqrt_min); }
K drift_rate(const Scene &s) { return card_value("drift_rate_nm_per_min", s.fw_cal.drift_rate_nm_per_min, kNominal.drift_rate_nm_per_min); }
K drift_scan(const Scene &s) { return card_value("drift_scan_sigma_nm", s.fw_cal.drift_scan_sigma_nm, kNominal.drift_scan_sigma_nm); }
SceneKeys kalman_keys(const Scene &s)
{
    if (!kalman(s)) return {};
    return {drift_walk(s), drift_rate(s), drift_scan(s), {"block_hz", s.block_hz}};
}
void fill_kalman(const Scene &s, fw_card_config_t *c)
{
    if (!kalman(s)) return;
    const double walk = drift_walk(s).second, rate = drift_rate(s).second / 60.0, scan = drift_scan(s).second;
    c->drift_kalman.period_us = fwu_i32(1e6 / s.block_hz);
    c->drift_kalman.walk_nm2_per_s = fwu_q16(walk * walk / 60.0);   // nm^2/min -> nm^2/s
    c->drift_kalman.vel_prior_nm2_per_s2 = fwu_q16(rate * rate);
    c->drift_scan_var_nm2 = fwu_q16(scan * scan);
}
constexpr const char *kScannerPrefix = "firmware.scanner.";
double scanner_origin_nm(const Scene &s, int axis) { return axis ? s.start_nm().y : s.start_nm().x; }
double scanner_range_nm(const Scene &s, int axis)
{
    const double c = axis ? s.field_center_nm.y : s.field_center_nm.x;
    return std::abs(scanner_origin_nm(s, axis) - c) + 0.6 * s.field_nm;
}
SceneKeys hyst_keys(const Scene &s, int axis)
{
    if (!s.fw_cal.hyst_enable || !s.fw_cal.scanner) return {};
    const FirmwareCalibration::ScannerAxis &a = s.fw_cal.scanner->axis[axis];
    const std::string k = std::string(kScannerPrefix) + (axis ? "y" : "x");
    SceneKeys out;
    for (std::size_t i = 0; i < a.r_nm.size(); ++i) out.push_back({k + ".r_nm[" + std::to_string(i) + "]", a.r_nm[i]});
    for (std::size_t i = 0; i < a.w.size(); ++i) out.push_back({k + ".w[" + std::to_string(i) + "]", a.w[i]});
    out.push_back({std::string("operator.path_nm[0][") + (axis ? "1]" : "0]"), scanner_origin_nm(s, axis)});
    out.push_back({"sample.field_nm", s.field_nm});
    return out;
}
void fill_hyst(const Scene &s, fw_card_config_t *c, int axis)
{
    if (!s.fw_cal.hyst_enable || !s.fw_cal.scanner) return;
    const FirmwareCalibration::ScannerAxis &a = s.fw_cal.scanner->axis[axis];
    fw_hyst_params_t &p = c->hyst[axis];
    p.n = static_cast<int32_t>(std::min<std::size_t>(a.r_nm.size(), FW_HYST_N_MAX));   // the reader held it to 1..16
    for (int32_t i = 0; i < p.n; ++i) {
        p.r_pm[i] = fwu_pm_from_nm(a.r_nm[static_cast<std::size_t>(i)]);
        p.w_q24[i] = fwu_q24(a.w[static_cast<std::size_t>(i)]);
    }
    p.range_pm = fwu_pm_from_nm(scanner_range_nm(s, axis));
    p.origin_pm = fwu_pm_from_nm(scanner_origin_nm(s, axis));
}

using S = const Scene &;
using C = fw_card_config_t *;

const std::vector<CardRow> kRows = {
    {"board.adc_bits", [](S s) -> SceneKeys { return {{"firmware.adc_bits", s.adc_bits}}; },
     [](S s, C c) { c->board.adc_bits = s.adc_bits; }, {FW_RULE_ADC_BITS}},
    {"word_bits", [](S s) -> SceneKeys { return {{"firmware.word_bits", s.word_bits}}; },
     [](S s, C c) { c->word_bits = s.word_bits; }, {FW_RULE_WORD_BITS, FW_RULE_WORD16_RANGE}},
    // The force interlock (fw_guard.h): the scene's limits, or 80 % of
    // each channel's full scale with the gains the card runs with.
    {"interlock_normal_pn", [](S s) -> SceneKeys { return {{"firmware.interlock_normal_nN", s.fw_cal.interlock_normal_nN.value_or(-1)}}; },
     [](S s, C c) {
         c->interlock_normal_pn = s.fw_cal.interlock_normal_nN ? fwu_pn_from_nn(*s.fw_cal.interlock_normal_nN)
                                                               : fw_guard_default_limit_pn(normal_gain_pn_per_v(s));
     },
     {FW_RULE_INTERLOCK_NORMAL}},
    {"interlock_lateral_pn", [](S s) -> SceneKeys { return {{"firmware.interlock_lateral_nN", s.fw_cal.interlock_lateral_nN.value_or(-1)}}; },
     [](S s, C c) {
         c->interlock_lateral_pn = s.fw_cal.interlock_lateral_nN ? fwu_pn_from_nn(*s.fw_cal.interlock_lateral_nN)
                                                                 : fw_guard_default_limit_pn(lateral_gain_pn_per_v(s));
     },
     {FW_RULE_INTERLOCK_LATERAL}},
    {"board.normal_gain_pn_per_v", [](S s) -> SceneKeys { return {spring(s), deflection(s)}; },
     [](S s, C c) { c->board.normal_gain_pn_per_v = normal_gain_pn_per_v(s); },
     {FW_RULE_FORCE_GAINS, FW_RULE_WORD16_RANGE, FW_RULE_INTERLOCK_NORMAL}},
    {"board.lateral_gain_pn_per_v", [](S s) -> SceneKeys { return {lateral(s)}; }, [](S s, C c) { c->board.lateral_gain_pn_per_v = lateral_gain_pn_per_v(s); },
     {FW_RULE_FORCE_GAINS, FW_RULE_WORD16_RANGE, FW_RULE_INTERLOCK_LATERAL}},
    {"board.mu_ppm", [](S s) -> SceneKeys { return {tip_mu(s)}; }, [](S s, C c) { c->board.mu_ppm = fwu_ppm(tip_mu(s).second); }, {FW_RULE_MU_RANGE, FW_RULE_MU_2H_OVER_L}},
    {"board.tip_height_nm", [](S s) -> SceneKeys { return {tip_height(s)}; },
     [](S s, C c) { c->board.tip_height_nm = fwu_nm_from_um(tip_height(s).second); },
     {FW_RULE_LEVER_POSITIVE, FW_RULE_TIP_SHORTER_THAN_LEVER, FW_RULE_MU_2H_OVER_L, FW_RULE_WORD16_RANGE}},
    {"board.deflection_pm_per_v", [](S s) -> SceneKeys { return {deflection(s)}; },
     [](S s, C c) { c->board.deflection_pm_per_v = fwu_pm_per_v_from_nm_per_v(deflection(s).second); },
     {FW_RULE_DEFLECTION_GAIN, FW_RULE_WORD16_RANGE}},
    {"board.lever_length_nm", [](S s) -> SceneKeys { return {lever_length(s)}; },
     [](S s, C c) { c->board.lever_length_nm = fwu_nm_from_um(lever_length(s).second); },
     {FW_RULE_LEVER_POSITIVE, FW_RULE_TIP_SHORTER_THAN_LEVER, FW_RULE_MU_2H_OVER_L, FW_RULE_WORD16_RANGE}},
    {"board.disp_n_pm_per_v",
     [](S s) { return disp_keys("disp_n_nm_per_V", s.fw_cal.disp_n_nm_per_V, calibrated(s, &FirmwareCalibration::Bench::disp_n_nm_per_V), s); },
     [](S s, C c) { c->board.disp_n_pm_per_v = disp_pm_per_v(disp_n(s), s); }, {FW_RULE_DISP_NEGATIVE, FW_RULE_DISP_RANGE}},
    {"board.disp_l_pm_per_v", [](S s) { return disp_keys("disp_l_nm_per_V", s.fw_cal.disp_l_nm_per_V, std::nullopt, s); },
     [](S s, C c) { c->board.disp_l_pm_per_v = disp_pm_per_v(s.fw_cal.disp_l_nm_per_V, s); }, {FW_RULE_DISP_NEGATIVE, FW_RULE_DISP_RANGE}},
    {"board.adhesion_pn", [](S s) -> SceneKeys { return {tip_adhesion(s)}; },
     [](S s, C c) { c->board.adhesion_pn = fwu_pn_from_nn(adhesion_if_on(s, tip_adhesion(s).second)); }, {FW_RULE_ADHESION}},
    {"board.scan_angle_mdeg", [](S s) -> SceneKeys { return {{"probe.scan_angle_deg", s.probe.scan_angle_deg}}; },
     [](S s, C c) { c->board.scan_angle_mdeg = fwu_mdeg_from_deg(s.probe.scan_angle_deg); }, {}},
    {"board.scan_center_pm",
     [](S s) -> SceneKeys { return {{"sample.field_center_nm[0]", s.field_center_nm.x}, {"sample.field_center_nm[1]", s.field_center_nm.y}}; },
     [](S s, C c) {
         c->board.scan_center_pm[0] = fwu_pm_from_nm(s.field_center_nm.x);
         c->board.scan_center_pm[1] = fwu_pm_from_nm(s.field_center_nm.y);
     },
     {}},
    {"board.scan_half_range_pm", [](S s) -> SceneKeys { return {{"sample.field_nm", s.field_nm}}; },
     [](S s, C c) { c->board.scan_half_range_pm = fwu_pm_from_nm(s.field_nm / 2); }, {FW_RULE_JOYSTICK_RANGE}},
    {"board.kappa_q16", [](S s) -> SceneKeys { return {{"operator.kappa", s.op.kappa}}; },
     [](S s, C c) { c->board.kappa_q16 = fwu_q16(s.op.kappa); }, {FW_RULE_JOYSTICK_RANGE}},
    {"tip_radius_pm", [](S s) -> SceneKeys { return {tip_radius(s)}; },
     [](S s, C c) { c->tip_radius_pm = fwu_pm_from_nm(tip_radius(s).second); }, {FW_RULE_TIP_RADIUS}},
    {"tip_half_angle_mdeg", [](S s) -> SceneKeys { return {half_angle(s)}; },
     [](S s, C c) { c->tip_half_angle_mdeg = fwu_mdeg_from_deg(half_angle(s).second); }, {FW_RULE_TIP_HALF_ANGLE}},
    {"particle_mu_ppm", [](S s) -> SceneKeys { return {particle_mu(s)}; },
     [](S s, C c) { c->particle_mu_ppm = fwu_ppm(particle_mu(s).second); }, {FW_RULE_PARTICLE}},
    {"particle_adhesion_pn", [](S s) -> SceneKeys { return {particle_adhesion(s)}; },
     [](S s, C c) { c->particle_adhesion_pn = fwu_pn_from_nn(adhesion_if_on(s, particle_adhesion(s).second)); }, {FW_RULE_PARTICLE}},
    {"particle_shear_kpa", [](S s) -> SceneKeys { return {particle_shear(s)}; },
     [](S s, C c) { c->particle_shear_kpa = fwu_kpa_from_mpa(particle_shear(s).second); }, {FW_RULE_PARTICLE}},
    {"particle_contact_area_nm2", [](S s) -> SceneKeys { return {particle_area(s)}; },
     [](S s, C c) { c->particle_contact_area_nm2 = fwu_i32(particle_area(s).second); }, {FW_RULE_PARTICLE}},
    {"wire_friction_pn_per_um", [](S s) -> SceneKeys { return {wire_friction(s)}; },
     [](S s, C c) { c->wire_friction_pn_per_um = fwu_pn_per_um_from_nn_per_um(wire_friction(s).second); }, {FW_RULE_WIRE_FRICTION}},
    {"wire_mu_ppm", [](S s) -> SceneKeys { return {wire_mu(s)}; }, [](S s, C c) { c->wire_mu_ppm = fwu_ppm(wire_mu(s).second); }, {FW_RULE_WIRE_FRICTION}},
    {"litho_threshold_pn", [](S s) -> SceneKeys { return {litho_threshold(s)}; },
     [](S s, C c) { c->litho_threshold_pn = fwu_pn_from_nn(litho_threshold(s).second); }, {FW_RULE_LITHO}},
    {"litho_depth_pm_per_pn", [](S s) -> SceneKeys { return {litho_depth(s)}; },
     [](S s, C c) { c->litho_depth_pm_per_pn = fwu_q16(litho_depth(s).second); }, {FW_RULE_LITHO}},   // nm/nN = pm/pN, 16.16
    // A landmark after a lever change may be anywhere in the field.
    {"landmark_max_step_pm", [](S s) -> SceneKeys { return {{"sample.field_nm", s.field_nm}}; },
     [](S s, C c) { c->landmark_max_step_pm = fwu_pm_from_nm(s.field_nm / 2); }, {FW_RULE_DRIFT_STEP}},
    // None: 0, the firmware's default (FW_DRIFT_MAX_STEP_DEFAULT_PM).
    {"drift_max_step_pm",
     [](S s) -> SceneKeys {
         if (!s.fw_cal.drift_max_step_nm) return {};
         return {{"firmware.drift_max_step_nm", *s.fw_cal.drift_max_step_nm}};
     },
     [](S s, C c) { c->drift_max_step_pm = s.fw_cal.drift_max_step_nm ? fwu_pm_from_nm(*s.fw_cal.drift_max_step_nm) : 0; },
     {FW_RULE_DRIFT_STEP}},
    {"drift_filter", [](S s) -> SceneKeys { return {{"firmware.drift_filter", kalman(s) ? 1 : 0}}; },
     [](S s, C c) { c->drift_filter = kalman(s) ? FW_DRIFT_FILTER_KALMAN : FW_DRIFT_FILTER_STEP; }, {FW_RULE_DRIFT_KALMAN}},
    {"drift_kalman", kalman_keys, fill_kalman, {FW_RULE_DRIFT_KALMAN}},
    // The gain in whole uN/pN (0.001 N/nN), or the stability bound's
    // (haptic_bound.hpp, from the board above); the device's force per axis.
    {"haptic_un_per_pn",
     [](S s) -> SceneKeys { return {{"operator.haptic.force_gain_N_per_nN", s.op.haptic.force_gain_N_per_nN.value_or(-1)}}; },
     [](S s, C c) {
         c->haptic_un_per_pn = s.op.haptic.force_gain_N_per_nN ? fwu_un_per_pn_from_n_per_nn(*s.op.haptic.force_gain_N_per_nN)
                                                               : haptic_auto_gain_un_per_pn(s, c->board);
     },
     {FW_RULE_HAPTIC}},
    {"haptic_max_un", [](S s) -> SceneKeys { return {{"operator.haptic.max_force_N", s.op.haptic.max_force_N}}; },
     [](S s, C c) { c->haptic_max_un = fwu_un_from_n(s.op.haptic.max_force_N); }, {FW_RULE_HAPTIC}},
    {"creep_enable", [](S s) -> SceneKeys { return {{"firmware.creep_enable", s.fw_cal.creep_enable ? 1 : 0}}; },
     [](S s, C c) { c->creep_enable = s.fw_cal.creep_enable; }, {FW_RULE_CREEP}},
    {"creep", creep_keys, fill_creep, {FW_RULE_CREEP}},
    {"hyst_enable", [](S s) -> SceneKeys { return {{"firmware.hyst_enable", s.fw_cal.hyst_enable ? 1 : 0}}; },
     [](S s, C c) { c->hyst_enable = s.fw_cal.hyst_enable; }, {FW_RULE_HYST}},
    {"hyst[0]", [](S s) { return hyst_keys(s, 0); }, [](S s, C c) { fill_hyst(s, c, 0); }, {FW_RULE_HYST}},
    {"hyst[1]", [](S s) { return hyst_keys(s, 1); }, [](S s, C c) { fill_hyst(s, c, 1); }, {FW_RULE_HYST}},
};

}  // namespace

const std::vector<CardRow> &card_rows()
{
    return kRows;
}

void fill_card_rows(const Scene &s, fw_card_config_t *c)
{
    for (const CardRow &r : card_rows()) r.fill(s, c);
}

std::vector<CardSource> card_sources(const Scene &s)
{
    std::vector<CardSource> out;
    const std::string nominal = kNominalSuffix;
    for (const CardRow &r : card_rows())
        for (auto &[key, value] : r.keys(s)) {
            std::string source = "scene configuration";
            if (key.size() > nominal.size() && key.compare(key.size() - nominal.size(), nominal.size(), nominal) == 0)
                source = "nominal";
            else if (key.rfind(kCalibrationPrefix, 0) == 0)
                source = "calibration run " + s.fw_cal.calibration->run;
            else if (key.rfind(kScannerPrefix, 0) == 0)
                source = "calibration run " + s.fw_cal.scanner->run;
            else if (key.rfind("firmware.", 0) == 0)
                source = "scene card section";
            out.push_back({r.field, key, value, source});
        }
    return out;
}

SceneKeys card_rule_keys(const Scene &s, fw_rule_t rule)
{
    SceneKeys out;
    for (const CardRow &r : card_rows()) {
        if (std::find(r.rules.begin(), r.rules.end(), rule) == r.rules.end()) continue;
        for (auto &k : r.keys(s)) {
            const auto named = [&](const auto &o) { return o.first == k.first; };
            if (std::none_of(out.begin(), out.end(), named)) out.push_back(std::move(k));
        }
    }
    return out;
}

}  // namespace afm
