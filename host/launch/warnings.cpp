#include "warnings.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

extern "C" {
#include "fw_board.h"
#include "fw_force.h"
#include "fw_guard.h"
}
#include "fw_units.h"

namespace afm {

namespace {

bool expects(const Scene &s, const char *check) { return std::find(s.expect.begin(), s.expect.end(), check) != s.expect.end(); }

std::string num(double v)
{
    char b[32];
    std::snprintf(b, sizeof b, "%.4g", v);
    return b;
}

// |sin| of the angle to the lever's axis below which F_x is unobservable:
// the firmware's S_HI (fw_force.h: S_LO plus the blend's span, 2.30).
double unobservable_sin()
{
    return static_cast<double>(FW_FORCE_SIN_HI_Q30) / static_cast<double>(1 << 30);
}

void unobservable_pushes(const Scene &s, std::vector<std::string> *out)
{
    if (s.op.plan.enabled || expects(s, "unobservable_push")) return;   // the planner keeps its pushes off the axis itself
    q30_t axis[2];
    fw_board_lever_axis_q30(fwu_mdeg_from_deg(s.probe.scan_angle_deg), axis);
    const double ax = fwu_from_q30(axis[0]), ay = fwu_from_q30(axis[1]);
    const auto &p = s.op.path_nm;
    for (std::size_t i = 1; i < p.size(); ++i) {
        const double dx = p[i].x - p[i - 1].x, dy = p[i].y - p[i - 1].y, len = std::hypot(dx, dy);
        if (len <= 0 || std::fabs(ax * dy - ay * dx) / len >= unobservable_sin()) continue;
        for (const auto &q : s.particles)
            if (point_segment_distance({q.x_nm, q.y_nm}, p[i - 1], p[i]) < q.radius_nm + s.probe.tip_radius_nm) {
                out->push_back("operator.path_nm[" + std::to_string(i) + "]: pushes particle " + std::to_string(q.id) +
                               " within " + num(std::asin(unobservable_sin()) * 180 / M_PI) +
                               " deg of the lever's axis, where the card cannot see F_x (its model stays behind)");
                break;
            }
    }
}

void loads(const Scene &s, const fw_card_config_t &card, std::vector<std::string> *out)
{
    const double full = fwu_nn_from_pn(fw_guard_full_scale_pn(card.board.normal_gain_pn_per_v));
    const double limit = fwu_nn_from_pn(card.interlock_normal_pn);
    std::vector<std::pair<std::string, double>> asked = {{"operator.load_nN", s.op.load_nN}};
    if (s.op.load_ramp_to_nN) asked.push_back({"operator.load_ramp_to_nN", *s.op.load_ramp_to_nN});
    for (std::size_t i = 0; i < s.op.plan.cuts.size(); ++i)
        asked.push_back({"operator.plan.cuts[" + std::to_string(i) + "].load_nN", s.op.plan.cuts[i].load_nN});
    // With the interlock on it trips before S_n saturates (its limit lies
    // below the full scale, the card's rule): that is the warning then.
    for (const auto &[key, load] : asked) {
        if (s.fw_cal.interlock && load > limit) {
            if (!expects(s, "interlock"))
                out->push_back(key + ": " + num(load) + " nN is beyond the card's interlock limit (" + num(limit) + " nN): it will trip");
        } else if (load > full && !expects(s, "saturation")) {
            out->push_back(key + ": " + num(load) + " nN is beyond the lever's range (k_n K_n 10 V = " + num(full) + " nN): S_n saturates");
        }
    }
}

}  // namespace

std::vector<std::string> scene_warnings(const Scene &s, const fw_card_config_t &card)
{
    std::vector<std::string> out;
    unobservable_pushes(s, &out);
    if (!s.particles.empty() && !s.has_effect("adhesion"))
        out.push_back("effects: the scene has particles to push but no adhesion effect: nothing holds them (the first touch slides them away)");
    loads(s, card, &out);
    return out;
}

}  // namespace afm
