#include "card_setup.hpp"

extern "C" {
#include "fw_calib.h"
#include "fw_units.h"
}

#include <sstream>

#include "card_table.hpp"

namespace afm {

CardSetup::CardSetup(const Scene &s)
{
    fill_card_rows(s, &cfg_);   // every scalar setting: card_table.hpp
    for (const auto &p : s.particles)
        particles_.push_back({p.id, fwu_pm_from_nm(p.x_nm), fwu_pm_from_nm(p.y_nm), fwu_pm_from_nm(p.radius_nm)});
    cfg_.down_force = s.has_effect("down_force");
    cfg_.particles = particles_.data();
    cfg_.n_particles = static_cast<int32_t>(particles_.size());
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
    cfg_.litho = s.has_effect("lithography");
    for (const auto &m : s.landmarks) landmarks_.push_back({m.id, fwu_pm_from_nm(m.x_nm), fwu_pm_from_nm(m.y_nm)});
    cfg_.landmarks = landmarks_.data();
    cfg_.n_landmarks = static_cast<int32_t>(landmarks_.size());
    cfg_.start_lifted = !s.start_engaged();
    cfg_.interlock = s.fw_cal.interlock;   // its limits are rows of the table

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
    const auto keys = card_rule_keys(s, rule);
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
