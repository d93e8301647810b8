#include "card_setup.hpp"

extern "C" {
#include "fw_calib.h"
#include "fw_units.h"
}

#include <sstream>

#include "haptic_bound.hpp"
#include <utility>

namespace afm {

namespace {

fw_board_config_t board_config(const Scene &s)
{
    const ProbeSpec &p = s.probe;
    fw_board_config_t b{};
    b.adc_bits = s.adc_bits;
    b.normal_gain_pn_per_v = fwu_pn_per_v_from_nn_per_v(p.spring_N_per_m * p.deflection_nm_per_V);   // N/m nm/V = nN/V
    // The lever's constants as the card has them: calibrated (firmware.*) or
    // the probe's; the displacement constants: calibrated or the estimate.
    const FirmwareCalibration &cal = s.fw_cal;
    b.lateral_gain_pn_per_v = fwu_pn_per_v_from_nn_per_v(cal.lateral_nN_per_V.value_or(p.lateral_nN_per_V));
    b.deflection_pm_per_v = fwu_pm_per_v_from_nm_per_v(p.deflection_nm_per_V);
    b.tip_height_nm = fwu_nm_from_um(p.tip_height_um);
    b.lever_length_nm = fwu_nm_from_um(p.lever_length_um);
    // firmware.compensate: false sets C = 0 (the piezo is taken as the apex)
    b.disp_n_pm_per_v = !s.compensate ? 0 : cal.disp_n_nm_per_V ? fwu_pm_per_v_from_nm_per_v(*cal.disp_n_nm_per_V) : FW_CARD_DISP_ESTIMATE;
    b.disp_l_pm_per_v = !s.compensate ? 0 : cal.disp_l_nm_per_V ? fwu_pm_per_v_from_nm_per_v(*cal.disp_l_nm_per_V) : FW_CARD_DISP_ESTIMATE;
    b.scan_angle_mdeg = fwu_mdeg_from_deg(p.scan_angle_deg);
    b.mu_ppm = fwu_ppm(cal.mu.value_or(s.tip_substrate.mu));
    b.adhesion_pn = fwu_pn_from_nn(s.has_effect("adhesion") ? s.tip_substrate.adhesion_nN : 0.0);
    b.scan_center_pm[0] = fwu_pm_from_nm(s.field_center_nm.x);
    b.scan_center_pm[1] = fwu_pm_from_nm(s.field_center_nm.y);
    b.scan_half_range_pm = fwu_pm_from_nm(s.field_nm / 2);
    b.kappa_q16 = fwu_q16(s.op.kappa);
    return b;
}

}  // namespace

CardSetup::CardSetup(const Scene &s)
{
    cfg_.board = board_config(s);
    cfg_.word_bits = s.word_bits;
    cfg_.tip_radius_pm = fwu_pm_from_nm(s.probe.tip_radius_nm);
    cfg_.tip_half_angle_mdeg = fwu_mdeg_from_deg(s.probe.tip_half_angle_deg);
    for (const auto &p : s.particles)
        particles_.push_back({p.id, fwu_pm_from_nm(p.x_nm), fwu_pm_from_nm(p.y_nm), fwu_pm_from_nm(p.radius_nm)});
    const ContactSpec &ps = s.particle_substrate;
    cfg_.down_force = s.has_effect("down_force");
    cfg_.particles = particles_.data();
    cfg_.n_particles = static_cast<int32_t>(particles_.size());
    cfg_.particle_mu_ppm = fwu_ppm(ps.mu);
    cfg_.particle_adhesion_pn = fwu_pn_from_nn(s.has_effect("adhesion") ? ps.adhesion_nN : 0.0);
    cfg_.particle_shear_kpa = fwu_kpa_from_mpa(ps.shear_strength_MPa);
    cfg_.particle_contact_area_nm2 = fwu_i32(ps.contact_area_nm2);
    for (const auto &w : s.wires) {
        fw_card_wire_t c{};
        c.id = w.id;
        c.a_pm[0] = fwu_pm_from_nm(w.x0_nm);
        c.a_pm[1] = fwu_pm_from_nm(w.y0_nm);
        c.b_pm[0] = fwu_pm_from_nm(w.x1_nm);
        c.b_pm[1] = fwu_pm_from_nm(w.y1_nm);
        c.diameter_pm = fwu_pm_from_nm(w.diameter_nm);
        wires_.push_back(c);
    }
    cfg_.wires = wires_.data();
    cfg_.n_wires = static_cast<int32_t>(wires_.size());
    cfg_.wire_friction_pn_per_um = fwu_pn_from_nn(s.wire_friction_nN_per_um());
    cfg_.wire_mu_ppm = fwu_ppm(s.wire_model.mu);
    cfg_.litho = s.has_effect("lithography");
    cfg_.litho_threshold_pn = fwu_pn_from_nn(s.litho.threshold_nN);
    cfg_.litho_depth_pm_per_pn = fwu_q16(s.litho.depth_nm_per_nN);   // nm/nN = pm/pN
    for (const auto &m : s.landmarks) landmarks_.push_back({m.id, fwu_pm_from_nm(m.x_nm), fwu_pm_from_nm(m.y_nm)});
    cfg_.landmarks = landmarks_.data();
    cfg_.n_landmarks = static_cast<int32_t>(landmarks_.size());
    if (s.fw_cal.drift_max_step_nm) cfg_.drift_max_step_pm = fwu_pm_from_nm(*s.fw_cal.drift_max_step_nm);
    // A landmark after a lever change may be anywhere in the field.
    cfg_.landmark_max_step_pm = fwu_pm_from_nm(s.field_nm / 2);
    // operator.haptic: the gain in whole uN/pN (0.001 N/nN), the device's force per axis.
    cfg_.haptic_un_per_pn = s.op.haptic.force_gain_N_per_nN ? fwu_un_per_pn_from_n_per_nn(*s.op.haptic.force_gain_N_per_nN)
                                                             : haptic_auto_gain_un_per_pn(s, cfg_.board);
    cfg_.haptic_max_un = fwu_un_from_n(s.op.haptic.max_force_N);
    cfg_.start_lifted = !s.start_engaged();
    // The force interlock (fw_guard.h): the scene's limits, or the
    // firmware's default, 80 % of each channel's full scale with the gains
    // the card runs with.
    cfg_.interlock = s.fw_cal.interlock;
    cfg_.interlock_normal_pn = s.fw_cal.interlock_normal_nN ? fwu_pn_from_nn(*s.fw_cal.interlock_normal_nN)
                                                            : fw_guard_default_limit_pn(cfg_.board.normal_gain_pn_per_v);
    cfg_.interlock_lateral_pn = s.fw_cal.interlock_lateral_nN ? fwu_pn_from_nn(*s.fw_cal.interlock_lateral_nN)
                                                              : fw_guard_default_limit_pn(cfg_.board.lateral_gain_pn_per_v);

    particle_store_.resize(particles_.size());
    wire_store_.resize(wires_.size());
    if (cfg_.litho) trench_store_.resize(kCardTrenchCapacity);
    scratch_.resize(static_cast<std::size_t>(s.samples_per_block()));
    storage_.particles = particle_store_.empty() ? nullptr : particle_store_.data();
    storage_.particle_capacity = static_cast<int32_t>(particle_store_.size());
    storage_.wires = wire_store_.empty() ? nullptr : wire_store_.data();
    storage_.wire_capacity = static_cast<int32_t>(wire_store_.size());
    storage_.trench = trench_store_.empty() ? nullptr : trench_store_.data();
    storage_.trench_capacity = static_cast<int32_t>(trench_store_.size());
    storage_.scratch = scratch_.data();
    storage_.scratch_len = static_cast<int32_t>(scratch_.size());
}

namespace {

// The scene keys whose values feed a rule, with the values as the scene
// holds them (this names inputs; the rule itself is the firmware's).
std::vector<std::pair<std::string, double>> rule_keys(const Scene &s, fw_rule_t rule)
{
    const ProbeSpec &p = s.probe;
    switch (rule) {
    case FW_RULE_ADC_BITS: return {{"firmware.adc_bits", s.adc_bits}};
    case FW_RULE_WORD_BITS: return {{"firmware.word_bits", s.word_bits}};
    case FW_RULE_WORD16_RANGE:
        return {{"firmware.word_bits", s.word_bits}, {"probe.spring_N_per_m", p.spring_N_per_m}, {"probe.deflection_nm_per_V", p.deflection_nm_per_V},
                {"probe.lateral_nN_per_V", p.lateral_nN_per_V}, {"probe.tip_height_um", p.tip_height_um},
                {"probe.lever_length_um", p.lever_length_um}};
    case FW_RULE_FORCE_GAINS:
        return {{"probe.spring_N_per_m", p.spring_N_per_m}, {"probe.deflection_nm_per_V", p.deflection_nm_per_V},
                {s.fw_cal.lateral_nN_per_V ? "firmware.lateral_nN_per_V" : "probe.lateral_nN_per_V", s.fw_cal.lateral_nN_per_V.value_or(p.lateral_nN_per_V)}};
    case FW_RULE_LEVER_POSITIVE:
    case FW_RULE_TIP_SHORTER_THAN_LEVER:
        return {{"probe.tip_height_um", p.tip_height_um}, {"probe.lever_length_um", p.lever_length_um}};
    case FW_RULE_MU_RANGE:
        return {{s.fw_cal.mu ? "firmware.mu" : "sample.tip_substrate.mu", s.fw_cal.mu.value_or(s.tip_substrate.mu)}};
    case FW_RULE_ADHESION: return {{"sample.tip_substrate.adhesion_nN", s.tip_substrate.adhesion_nN}};
    case FW_RULE_MU_2H_OVER_L:
        return {{"sample.tip_substrate.mu", s.tip_substrate.mu}, {"probe.tip_height_um", p.tip_height_um},
                {"probe.lever_length_um", p.lever_length_um}};
    case FW_RULE_DEFLECTION_GAIN: return {{"probe.deflection_nm_per_V", p.deflection_nm_per_V}};
    case FW_RULE_DISP_NEGATIVE:
    case FW_RULE_DISP_RANGE:
        if (s.fw_cal.disp_n_nm_per_V || s.fw_cal.disp_l_nm_per_V)
            return {{"firmware.disp_n_nm_per_V", s.fw_cal.disp_n_nm_per_V.value_or(-1)}, {"firmware.disp_l_nm_per_V", s.fw_cal.disp_l_nm_per_V.value_or(-1)}};
        return {{"probe.tip_height_um", p.tip_height_um}, {"probe.deflection_nm_per_V", p.deflection_nm_per_V}, {"probe.lever_length_um", p.lever_length_um}};
    case FW_RULE_JOYSTICK_RANGE: return {{"sample.field_nm", s.field_nm}, {"operator.kappa", s.op.kappa}};
    case FW_RULE_TIP_RADIUS: return {{"probe.tip_radius_nm", p.tip_radius_nm}};
    case FW_RULE_PARTICLE:
        return {{"sample.particle_substrate.mu", s.particle_substrate.mu},
                {"sample.particle_substrate.adhesion_nN", s.particle_substrate.adhesion_nN},
                {"sample.particle_substrate.shear_strength_MPa", s.particle_substrate.shear_strength_MPa},
                {"sample.particle_substrate.contact_area_nm2", s.particle_substrate.contact_area_nm2}};
    case FW_RULE_WIRE_FRICTION:
        return {{"sample.wire.friction_nN_per_um", s.wire_friction_nN_per_um()}, {"sample.wire.mu", s.wire_model.mu}};
    case FW_RULE_LITHO:
        return {{"sample.lithography.threshold_nN", s.litho.threshold_nN}, {"sample.lithography.depth_nm_per_nN", s.litho.depth_nm_per_nN}};
    case FW_RULE_TIP_HALF_ANGLE: return {{"probe.tip_half_angle_deg", p.tip_half_angle_deg}};
    case FW_RULE_DRIFT_STEP: return {{"sample.field_nm", s.field_nm}};
    case FW_RULE_INTERLOCK_NORMAL:
        return {{"firmware.interlock_normal_nN", s.fw_cal.interlock_normal_nN.value_or(-1)}, {"probe.spring_N_per_m", p.spring_N_per_m},
                {"probe.deflection_nm_per_V", p.deflection_nm_per_V}};
    case FW_RULE_INTERLOCK_LATERAL:
        return {{"firmware.interlock_lateral_nN", s.fw_cal.interlock_lateral_nN.value_or(-1)},
                {s.fw_cal.lateral_nN_per_V ? "firmware.lateral_nN_per_V" : "probe.lateral_nN_per_V", s.fw_cal.lateral_nN_per_V.value_or(p.lateral_nN_per_V)}};
    case FW_RULE_HAPTIC:
        return {{"operator.haptic.force_gain_N_per_nN", s.op.haptic.force_gain_N_per_nN.value_or(-1)}, {"operator.haptic.max_force_N", s.op.haptic.max_force_N}};
    default: return {};
    }
}

// What the firmware derived from those keys, where the rule is about it
// (the firmware's own estimate: nothing is computed here).
std::string rule_derived(const fw_card_config_t &c, fw_rule_t rule)
{
    std::ostringstream m;
    m.precision(7);
    const fw_board_config_t &b = c.board;
    int32_t est = 0;
    if ((rule == FW_RULE_DISP_RANGE || rule == FW_RULE_DISP_NEGATIVE) &&
        fw_calib_disp_estimate(b.tip_height_nm, b.lever_length_nm, b.deflection_pm_per_v, &est) == FW_OK)
        m << "; the firmware's estimate C_n = C_l = 3 h K_n / (2 l) = " << fwu_nm_from_pm(est) << " nm/V";
    if (rule == FW_RULE_INTERLOCK_NORMAL)
        m << "; the card's normal full scale k_n K_n 10 V = " << fwu_nn_from_pn(fw_guard_full_scale_pn(b.normal_gain_pn_per_v)) << " nN";
    if (rule == FW_RULE_INTERLOCK_LATERAL)
        m << "; the card's lateral full scale k_theta K_l / h 10 V = " << fwu_nn_from_pn(fw_guard_full_scale_pn(b.lateral_gain_pn_per_v))
          << " nN";
    return m.str();
}

const char *status_name(fw_status_t st)
{
    switch (st) {
    case FW_OK: return "FW_OK";
    case FW_ERR_ARG: return "FW_ERR_ARG";
    case FW_ERR_DOMAIN: return "FW_ERR_DOMAIN";
    case FW_ERR_CAPACITY: return "FW_ERR_CAPACITY";
    case FW_ERR_STATE: return "FW_ERR_STATE";
    }
    return "unknown status";
}

}  // namespace

std::string card_refusal_text(const Scene &s, const CardSetup &setup, fw_rule_t rule)
{
    const auto keys = rule_keys(s, rule);
    std::ostringstream m;
    m.precision(7);
    m << (keys.empty() ? std::string("firmware") : keys.front().first) << ": the firmware's card refuses it: "
      << fw_rule_text(rule) << " (fw_card_init: " << status_name(fw_rule_status(rule)) << ", rule " << static_cast<int>(rule)
      << ")";
    if (!keys.empty()) {
        m << "; got";
        for (std::size_t i = 0; i < keys.size(); ++i) m << (i ? ", " : " ") << keys[i].first << " " << keys[i].second;
    }
    m << rule_derived(setup.config(), rule);
    return m.str();
}

std::string card_refusal(const Scene &s)
{
    const CardSetup setup(s);
    fw_card_t card;
    fw_rule_t rule = FW_RULE_OK;
    if (fw_card_init(&card, &setup.config(), &setup.storage(), &rule) == FW_OK) return "";
    return card_refusal_text(s, setup, rule);
}

}  // namespace afm
