#include "operator.hpp"

#include <nlohmann/json.hpp>

#include "card_setup.hpp"

namespace afm {

namespace {

nlohmann::json plan_json(const Planner &p)
{
    using nlohmann::json;
    const PlanReport &r = p.report();
    json items = json::array();
    int placed = 0, particles = 0;
    for (const auto &i : r.items) {
        json j = {{"kind", i.kind}, {"id", i.id}, {"target_nm", {i.target_nm.x, i.target_nm.y}}, {"pushes", i.pushes}, {"scans", i.scans},
                  {"placed", i.placed}, {"error_nm", i.error_nm < 0 ? json(nullptr) : json(i.error_nm)}};
        if (i.kind == "wire") j["target_angle_deg"] = i.target_angle_deg;
        if (!i.why.empty()) j["why"] = i.why;
        if (!i.note.empty()) j["note"] = i.note;
        items.push_back(j);
        if (i.kind == "particle") {
            ++particles;
            placed += i.placed;
        }
    }
    return json{{"sites", p.sites().size()},
                {"particles_assigned", particles},
                {"placed_by_its_check", placed},
                {"pushes", r.pushes},
                {"repushes", r.repushes},
                {"cleared", r.cleared},
                {"disturbed", r.disturbed},
                {"replaced", r.replaced},
                {"local_scans", r.local_scans},
                {"fixes", r.fixes},
                {"fixes_refused", r.fixes_refused},
                {"cuts", r.cuts},
                {"cuts_done_sim_s", r.cuts_done_s < 0 ? json(nullptr) : json(r.cuts_done_s)},
                {"finished_sim_s", r.finished_s < 0 ? json(nullptr) : json(r.finished_s)},
                {"planner_wall_s", r.wall_s},
                {"items", items}};
}

}  // namespace

nlohmann::json operator_report(const Operator &op, const Planner *planner, const Scene &scene, const nlohmann::json &rejected)
{
    nlohmann::json rep = {{"poses", op.forces}, {"peak_haptic_force_N", op.peak_force_N}, {"rejected", rejected}};
    if (planner) {
        rep["plan"] = plan_json(*planner);
    } else {
        const CardSetup card(scene);
        const HapticBound b = haptic_bound(scene, card.config());
        rep["mode"] = scene.op.mode;
        rep["haptic"] = {{"gain_N_per_nN", b.gain_N_per_N * 1e-9},
                         {"rendered_stiffness_N_per_m", b.rendered_N_per_m},
                         {"passivity_bound_N_per_m", b.max_rendered_N_per_m},
                         {"passive", b.passive},
                         {"largest_passive_gain_N_per_nN", b.max_gain_N_per_nN},
                         {"controller_energy_J", op.device.controller_energy_J()},
                         {"controller_blocks", op.device.controller_blocks()},
                         {"observed_energy_J", op.device.observed_energy_J()},
                         {"workspace_edge_blocks", op.device.edge_blocks()},
                         {"z_axis", scene.op.haptic.load_span_nN > 0
                                        ? nlohmann::json{{"load_span_nN", scene.op.haptic.load_span_nN},
                                                         {"rendered_stiffness_N_per_m", b.rendered_z_N_per_m},
                                                         {"peak_force_z_N", op.peak_force_z_N},
                                                         {"final_load_nN", op.device.load_nN()}}
                                        : nlohmann::json(nullptr)},
                         {"peak_stylus_speed_m_per_s", op.peak_speed_m_per_s},
                         {"device_damping_Ns_per_m", scene.op.haptic.damping_Ns_per_m},
                         {"hand", {{"stiffness_N_per_m", scene.op.hand.stiffness_N_per_m},
                                   {"damping_Ns_per_m", scene.op.hand.damping_Ns_per_m},
                                   {"mass_kg", scene.op.hand.mass_kg}}}};
        nlohmann::json contacts = nlohmann::json::array();
        for (const auto &c : op.script.contacts())
            contacts.push_back({{"t_s", c.t_s}, {"aim_nm", {c.aim_nm.x, c.aim_nm.y}}, {"force_N", c.force_N}, {"stroke", c.stroke}});
        rep["contacts_felt"] = contacts;
        if (op.page) rep["browser"] = {{"commands", op.page->taken()}, {"refused", op.page->refused()},
                                        {"scans_asked", op.page->scans_asked()}, {"scans", op.scans}};
    }
    return rep;
}

}  // namespace afm
