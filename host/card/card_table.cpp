#include "card_table.hpp"

extern "C" {
#include "fw_calib.h"
#include "fw_guard.h"
#include "fw_units.h"
}

#include <algorithm>

#include "haptic_bound.hpp"

namespace afm {

namespace {

// The lever's lateral constant as the card has it: calibrated, or the probe's.
double lateral_nN_per_V(const Scene &s)
{
    return s.fw_cal.lateral_nN_per_V.value_or(s.probe.lateral_nN_per_V);
}
SceneKeys lateral_key(const Scene &s)
{
    return {{s.fw_cal.lateral_nN_per_V ? "firmware.lateral_nN_per_V" : "probe.lateral_nN_per_V", lateral_nN_per_V(s)}};
}
// k_n K_n and k_theta K_l / h, pN/V (the interlock's default limits read them too).
int32_t normal_gain_pn_per_v(const Scene &s)
{
    return fwu_pn_per_v_from_nn_per_v(s.probe.spring_N_per_m * s.probe.deflection_nm_per_V);   // N/m nm/V = nN/V
}
int32_t lateral_gain_pn_per_v(const Scene &s)
{
    return fwu_pn_per_v_from_nn_per_v(lateral_nN_per_V(s));
}
// C_n or C_l: calibrated (firmware.*), or the firmware's estimate from h, K_n and l.
SceneKeys disp_keys(const char *key, const std::optional<double> &cal, const Scene &s)
{
    if (cal) return {{key, *cal}};
    return {{"probe.tip_height_um", s.probe.tip_height_um}, {"probe.deflection_nm_per_V", s.probe.deflection_nm_per_V},
            {"probe.lever_length_um", s.probe.lever_length_um}};
}
int32_t disp_pm_per_v(const std::optional<double> &cal, const Scene &s)
{
    if (!s.compensate) return 0;   // firmware.compensate: false: the piezo is taken as the apex
    return cal ? fwu_pm_per_v_from_nm_per_v(*cal) : FW_CARD_DISP_ESTIMATE;
}
double adhesion_if_on(const Scene &s, double nN)
{
    return s.has_effect("adhesion") ? nN : 0.0;
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
    {"board.normal_gain_pn_per_v",
     [](S s) -> SceneKeys { return {{"probe.spring_N_per_m", s.probe.spring_N_per_m}, {"probe.deflection_nm_per_V", s.probe.deflection_nm_per_V}}; },
     [](S s, C c) { c->board.normal_gain_pn_per_v = normal_gain_pn_per_v(s); },
     {FW_RULE_FORCE_GAINS, FW_RULE_WORD16_RANGE, FW_RULE_INTERLOCK_NORMAL}},
    {"board.lateral_gain_pn_per_v", lateral_key, [](S s, C c) { c->board.lateral_gain_pn_per_v = lateral_gain_pn_per_v(s); },
     {FW_RULE_FORCE_GAINS, FW_RULE_WORD16_RANGE, FW_RULE_INTERLOCK_LATERAL}},
    {"board.mu_ppm",
     [](S s) -> SceneKeys { return {{s.fw_cal.mu ? "firmware.mu" : "sample.tip_substrate.mu", s.fw_cal.mu.value_or(s.tip_substrate.mu)}}; },
     [](S s, C c) { c->board.mu_ppm = fwu_ppm(s.fw_cal.mu.value_or(s.tip_substrate.mu)); }, {FW_RULE_MU_RANGE, FW_RULE_MU_2H_OVER_L}},
    {"board.tip_height_nm", [](S s) -> SceneKeys { return {{"probe.tip_height_um", s.probe.tip_height_um}}; },
     [](S s, C c) { c->board.tip_height_nm = fwu_nm_from_um(s.probe.tip_height_um); },
     {FW_RULE_LEVER_POSITIVE, FW_RULE_TIP_SHORTER_THAN_LEVER, FW_RULE_MU_2H_OVER_L, FW_RULE_WORD16_RANGE}},
    {"board.deflection_pm_per_v", [](S s) -> SceneKeys { return {{"probe.deflection_nm_per_V", s.probe.deflection_nm_per_V}}; },
     [](S s, C c) { c->board.deflection_pm_per_v = fwu_pm_per_v_from_nm_per_v(s.probe.deflection_nm_per_V); },
     {FW_RULE_DEFLECTION_GAIN, FW_RULE_WORD16_RANGE}},
    {"board.lever_length_nm", [](S s) -> SceneKeys { return {{"probe.lever_length_um", s.probe.lever_length_um}}; },
     [](S s, C c) { c->board.lever_length_nm = fwu_nm_from_um(s.probe.lever_length_um); },
     {FW_RULE_LEVER_POSITIVE, FW_RULE_TIP_SHORTER_THAN_LEVER, FW_RULE_MU_2H_OVER_L, FW_RULE_WORD16_RANGE}},
    {"board.disp_n_pm_per_v", [](S s) { return disp_keys("firmware.disp_n_nm_per_V", s.fw_cal.disp_n_nm_per_V, s); },
     [](S s, C c) { c->board.disp_n_pm_per_v = disp_pm_per_v(s.fw_cal.disp_n_nm_per_V, s); }, {FW_RULE_DISP_NEGATIVE, FW_RULE_DISP_RANGE}},
    {"board.disp_l_pm_per_v", [](S s) { return disp_keys("firmware.disp_l_nm_per_V", s.fw_cal.disp_l_nm_per_V, s); },
     [](S s, C c) { c->board.disp_l_pm_per_v = disp_pm_per_v(s.fw_cal.disp_l_nm_per_V, s); }, {FW_RULE_DISP_NEGATIVE, FW_RULE_DISP_RANGE}},
    {"board.adhesion_pn", [](S s) -> SceneKeys { return {{"sample.tip_substrate.adhesion_nN", s.tip_substrate.adhesion_nN}}; },
     [](S s, C c) { c->board.adhesion_pn = fwu_pn_from_nn(adhesion_if_on(s, s.tip_substrate.adhesion_nN)); }, {FW_RULE_ADHESION}},
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
    {"tip_radius_pm", [](S s) -> SceneKeys { return {{"probe.tip_radius_nm", s.probe.tip_radius_nm}}; },
     [](S s, C c) { c->tip_radius_pm = fwu_pm_from_nm(s.probe.tip_radius_nm); }, {FW_RULE_TIP_RADIUS}},
    {"tip_half_angle_mdeg", [](S s) -> SceneKeys { return {{"probe.tip_half_angle_deg", s.probe.tip_half_angle_deg}}; },
     [](S s, C c) { c->tip_half_angle_mdeg = fwu_mdeg_from_deg(s.probe.tip_half_angle_deg); }, {FW_RULE_TIP_HALF_ANGLE}},
    {"particle_mu_ppm", [](S s) -> SceneKeys { return {{"sample.particle_substrate.mu", s.particle_substrate.mu}}; },
     [](S s, C c) { c->particle_mu_ppm = fwu_ppm(s.particle_substrate.mu); }, {FW_RULE_PARTICLE}},
    {"particle_adhesion_pn", [](S s) -> SceneKeys { return {{"sample.particle_substrate.adhesion_nN", s.particle_substrate.adhesion_nN}}; },
     [](S s, C c) { c->particle_adhesion_pn = fwu_pn_from_nn(adhesion_if_on(s, s.particle_substrate.adhesion_nN)); }, {FW_RULE_PARTICLE}},
    {"particle_shear_kpa",
     [](S s) -> SceneKeys { return {{"sample.particle_substrate.shear_strength_MPa", s.particle_substrate.shear_strength_MPa}}; },
     [](S s, C c) { c->particle_shear_kpa = fwu_kpa_from_mpa(s.particle_substrate.shear_strength_MPa); }, {FW_RULE_PARTICLE}},
    {"particle_contact_area_nm2",
     [](S s) -> SceneKeys { return {{"sample.particle_substrate.contact_area_nm2", s.particle_substrate.contact_area_nm2}}; },
     [](S s, C c) { c->particle_contact_area_nm2 = fwu_i32(s.particle_substrate.contact_area_nm2); }, {FW_RULE_PARTICLE}},
    {"wire_friction_pn_per_um", [](S s) -> SceneKeys { return {{"sample.wire.friction_nN_per_um", s.wire_friction_nN_per_um()}}; },
     [](S s, C c) { c->wire_friction_pn_per_um = fwu_pn_per_um_from_nn_per_um(s.wire_friction_nN_per_um()); }, {FW_RULE_WIRE_FRICTION}},
    {"wire_mu_ppm", [](S s) -> SceneKeys { return {{"sample.wire.mu", s.wire_model.mu}}; },
     [](S s, C c) { c->wire_mu_ppm = fwu_ppm(s.wire_model.mu); }, {FW_RULE_WIRE_FRICTION}},
    {"litho_threshold_pn", [](S s) -> SceneKeys { return {{"sample.lithography.threshold_nN", s.litho.threshold_nN}}; },
     [](S s, C c) { c->litho_threshold_pn = fwu_pn_from_nn(s.litho.threshold_nN); }, {FW_RULE_LITHO}},
    {"litho_depth_pm_per_pn", [](S s) -> SceneKeys { return {{"sample.lithography.depth_nm_per_nN", s.litho.depth_nm_per_nN}}; },
     [](S s, C c) { c->litho_depth_pm_per_pn = fwu_q16(s.litho.depth_nm_per_nN); }, {FW_RULE_LITHO}},   // nm/nN = pm/pN, 16.16
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
