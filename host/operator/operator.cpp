#include "operator.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>

#include "card_setup.hpp"
#include "lockstep.hpp"

namespace afm {

namespace {

// The firmware's drift estimate (frame A, nm): what the card adds to the
// joystick's workspace (joy_of), 0 before its first objects.
Vec2 drift_of(const ObjectsView &view)
{
    if (!view.ready()) return {0, 0};
    return {view.whole().drift_nm[0], view.whole().drift_nm[1]};
}

// The page's news of a stroke, on the operator's heartbeat (analysis/view/live.py reads it).
std::string stroke_news(const char *what, const HandInput::PushAsk &a, const PlanItem *item)
{
    char head[160];
    std::snprintf(head, sizeof head, "push: %s id=%d x_nm=%.1f y_nm=%.1f", what, a.id, a.target_nm.x, a.target_nm.y);
    std::string out = head;
    if (!item) return out;
    char tail[120];
    if (std::string(what) == "progress")   // so far: no outcome yet
        std::snprintf(tail, sizeof tail, " pushes=%d scans=%d", item->pushes, item->scans);
    else
        std::snprintf(tail, sizeof tail, " placed=%d error_nm=%.1f pushes=%d scans=%d", item->placed ? 1 : 0, item->error_nm,
                      item->pushes, item->scans);
    out += tail;
    if (!item->why.empty()) out += " why=" + item->why;
    return out;
}

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

// operator_report.json's "browser": what the page asked for and what came of it.
static nlohmann::json browser_json(const Operator &op)
{
    using nlohmann::json;
    json strokes = json::array();
    for (const StrokeDone &d : op.strokes_done) {
        const PlanItem &i = d.item;
        strokes.push_back({{"id", i.id}, {"asked_nm", {d.asked_nm.x, d.asked_nm.y}}, {"started_sim_s", d.started_s},
                           {"ended_sim_s", d.ended_s}, {"placed", i.placed}, {"error_nm", i.error_nm < 0 ? json(nullptr) : json(i.error_nm)},
                           {"pushes", i.pushes}, {"scans", i.scans}, {"why", i.why}});
    }
    const HandInput &p = *op.page;
    json j = {{"commands", p.taken()}, {"refused", p.refused()}, {"refusals", p.refusals()},
              {"scans_asked", p.scans_asked()}, {"scans", op.page_scans},
              {"pushes_asked", p.pushes_asked()}, {"hand_lines_held", p.held()}, {"strokes", strokes},
              {"stroke_under_way_at_end", op.stroke ? json(op.stroke->ask.id) : json(nullptr)}};
    if (op.stroke_planner) {
        const PlanReport &r = op.stroke_planner->report();
        j["stroke_planner"] = {{"pushes", r.pushes}, {"repushes", r.repushes}, {"local_scans", r.local_scans},
                               {"fixes", r.fixes}, {"fixes_refused", r.fixes_refused}, {"disturbed", r.disturbed}};
        const PlanSpec &ps = op.scene.op.plan;   // the strokes' settings (operator.plan, else its defaults)
        j["stroke_planner"]["settings"] = {{"tolerance_nm", ps.tolerance_nm}, {"speed_nm_per_s", ps.speed_nm_per_s},
                                           {"travel_speed_nm_per_s", ps.travel_speed_nm_per_s},
                                           {"scan_size_nm", ps.scan_size_nm}, {"max_pushes", ps.max_pushes}};
    }
    return j;
}

void Operator::start_stroke(const HandInput::PushAsk &a)
{
    // the tip where the hand holds it (the last pose), in frame A
    const Vec2 d = drift_of(view);
    const Vec2 tip{scene.field_center_nm.x + last.joy[0] * reach_nm + d.x, scene.field_center_nm.y + last.joy[1] * reach_nm + d.y};
    stroke = std::make_unique<Stroke>();
    stroke->ask = a;
    stroke->started_s = block_end_utime(scene, force.seq) * 1e-6;
    stroke->pushes0 = stroke_planner->report().pushes;
    stroke->scans0 = stroke_planner->report().local_scans;
    stroke->told = std::chrono::steady_clock::now();
    page->yield(true);
    Stroke *st = stroke.get();
    Planner *pl = stroke_planner.get();
    st->thread = std::thread([st, pl, a, tip] {
        try {
            st->item = pl->push_particle(st->turns, a.id, a.target_nm, tip);
            st->turns.finish(nullptr);
        } catch (const PlanStopped &) {
        } catch (const PlanError &e) {   // this stroke cannot be made: its account says why
            st->item.id = a.id;
            st->item.why = e.what();
            st->turns.finish(nullptr);
        } catch (...) {
            st->turns.finish(std::current_exception());
        }
    });
    hb.send(RunState::running, force.seq, block_end_utime(scene, force.seq), stroke_news("start", a, nullptr));
}

void Operator::serve_stroke()
{
    const Turn t = serve_planner(stroke->turns, stroke->served_block);
    if (t == Turn::run_over) return;
    if (t == Turn::ended) {
        if (const std::exception_ptr e = stroke->turns.error()) std::rethrow_exception(e);
        end_stroke();
        return;
    }
    stroke->served_block = true;
    // the stylus carried along with the tip (the hand's aim on it), nothing rendered
    const Vec2 d = drift_of(view);
    const bool has_z = scene.op.haptic.load_span_nN > 0;
    device.step(to_stylus(scene, {hold_pose.tip_nm.x - d.x, hold_pose.tip_nm.y - d.y}), {0, 0},
                has_z ? press_for(page->command().load_nN) : 0.0, 0);
    held_N = {0, 0};
    held_z_N = 0;
    // its progress, for the page; the planner's thread waits for this block's model meanwhile (PlannerTurns)
    if (std::chrono::steady_clock::now() - stroke->told >= std::chrono::milliseconds(kStrokeNewsMs)) {
        PlanItem so_far;
        so_far.id = stroke->ask.id;
        so_far.pushes = stroke_planner->report().pushes - stroke->pushes0;
        so_far.scans = stroke_planner->report().local_scans - stroke->scans0;
        hb.send(RunState::running, force.seq, block_end_utime(scene, force.seq), stroke_news("progress", stroke->ask, &so_far));
        stroke->told = std::chrono::steady_clock::now();
    }
}

void Operator::end_stroke()
{
    StrokeDone done{stroke->item, stroke->ask.target_nm, stroke->started_s, block_end_utime(scene, force.seq) * 1e-6};
    const HandInput::PushAsk a = stroke->ask;
    stroke.reset();   // its thread has finished: joined
    strokes_done.push_back(done);
    page->poll();     // the hand's lines sent while the stroke ran are held, not taken
    const Vec2 d = drift_of(view);
    page->hand_back({hold_pose.tip_nm.x - d.x, hold_pose.tip_nm.y - d.y});
    hb.send(RunState::running, force.seq, block_end_utime(scene, force.seq), stroke_news("end", a, &done.item));
    publish_pose(joy_of(hold_pose.tip_nm), false, page->command().load_nN);
}

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
        if (op.page) rep["browser"] = browser_json(op);
    }
    return rep;
}

}  // namespace afm
