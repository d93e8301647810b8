// The scene's operator (haptic device, plan, path, local scans, cantilever
// changes), outputs and expect sections (scene_reader.hpp).
#include "scene_reader.hpp"

namespace afm::scene_detail {

// operator.haptic, operator.hand: the device and the hand holding it.
void read_haptic(const Reader &r, const YAML::Node &op, Scene &s)
{
    const HapticSpec dh;
    YAML::Node h = op["haptic"];
    if (h.IsDefined() && !h.IsNull()) {
        const std::string k = "operator.haptic";
        r.only_keys(h, k, {"half_range_mm", "max_force_N", "max_stiffness_N_per_m", "force_gain_N_per_nN", "damping_Ns_per_m",
                           "passivity_check", "load_span_nN"});
        s.op.haptic.half_range_mm = r.num(h, k, "half_range_mm", &dh.half_range_mm);
        s.op.haptic.max_force_N = r.num(h, k, "max_force_N", &dh.max_force_N);
        s.op.haptic.max_stiffness_N_per_m = r.num(h, k, "max_stiffness_N_per_m", &dh.max_stiffness_N_per_m);
        const YAML::Node g = h["force_gain_N_per_nN"];
        if (g.IsDefined() && !g.IsNull() && !(g.IsScalar() && g.Scalar() == "auto"))
            s.op.haptic.force_gain_N_per_nN = r.num(h, k, "force_gain_N_per_nN", nullptr);
        s.op.haptic.damping_Ns_per_m = r.num(h, k, "damping_Ns_per_m", &dh.damping_Ns_per_m);
        s.op.haptic.passivity_check = r.boolean(h, k, "passivity_check", true);
        s.op.haptic.load_span_nN = r.num(h, k, "load_span_nN", &dh.load_span_nN);
    }
    const HandSpec dd;
    YAML::Node hand = op["hand"];
    if (hand.IsDefined() && !hand.IsNull()) {
        const std::string k = "operator.hand";
        r.only_keys(hand, k, {"stiffness_N_per_m", "damping_Ns_per_m", "mass_kg"});
        s.op.hand.stiffness_N_per_m = r.num(hand, k, "stiffness_N_per_m", &dd.stiffness_N_per_m);
        s.op.hand.damping_Ns_per_m = r.num(hand, k, "damping_Ns_per_m", &dd.damping_Ns_per_m);
        s.op.hand.mass_kg = r.num(hand, k, "mass_kg", &dd.mass_kg);
    }
}

// operator.plan.cuts: lines cut before the pushes (lithography), inside the
// joystick's reach, pressed above the threshold (else nothing is cut).
void read_plan_cuts(const Reader &r, const YAML::Node &n, Scene &s)
{
    if (!n.IsDefined() || n.IsNull()) return;
    const std::string k = "operator.plan.cuts";
    if (!n.IsSequence()) r.fail(k, "must be a list, got " + Reader::show(n));
    if (n.size() > 0 && !s.has_effect("lithography"))
        r.fail(k, "cutting needs the lithography effect (effects: [..., lithography])");
    const double reach = s.field_nm / 2;
    for (std::size_t i = 0; i < n.size(); ++i) {
        const std::string p = k + "[" + std::to_string(i) + "]";
        r.only_keys(n[i], p, {"from_nm", "to_nm", "load_nN"});
        CutSpec c;
        c.from_nm = r.vec2(n[i]["from_nm"], p + ".from_nm");
        c.to_nm = r.vec2(n[i]["to_nm"], p + ".to_nm");
        for (const auto &[end, v] : {std::pair{"from_nm", c.from_nm}, std::pair{"to_nm", c.to_nm}})
            if (std::fabs(v.x - s.field_center_nm.x) > reach || std::fabs(v.y - s.field_center_nm.y) > reach)
                r.fail(p + "." + end, "is outside the field, got " + Reader::show(n[i][end]));
        c.load_nN = r.num(n[i], p, "load_nN", nullptr);
        if (c.load_nN <= s.litho.threshold_nN)
            r.fail(p + ".load_nN", "must exceed sample.lithography.threshold_nN (" + std::to_string(s.litho.threshold_nN) +
                                       ") or nothing is cut, got " + Reader::show(n[i]["load_nN"]));
        s.op.plan.cuts.push_back(c);
    }
}

// operator.plan: the automatic planner's settings (its presence turns it
// on). With operator.mode: browser it only sets the strokes a person asks
// for on the page (tolerance, speeds, scans, pushes): the planner is not
// turned on, and cuts, which only the automatic planner makes, are refused.
// The same with operator.mode: env (the pushes a program asks for).
void read_plan(const Reader &r, const YAML::Node &op, Scene &s)
{
    YAML::Node n = op["plan"];
    if (!n.IsDefined()) return;
    const std::string k = "operator.plan";
    PlanSpec &p = s.op.plan;
    const PlanSpec d;
    const bool browser = s.op.mode == "browser" || s.op.mode == "env";
    p.enabled = !browser;
    if (n.IsNull()) return;
    if (browser && n.IsMap() && n["cuts"].IsDefined())
        r.fail(k + ".cuts", "the automatic planner's: with operator.mode: " + s.op.mode + " operator.plan sets only the strokes asked for");
    r.only_keys(n, k, {"tolerance_nm", "speed_nm_per_s", "travel_speed_nm_per_s", "scan_size_nm", "scan_px", "scan_s",
                       "max_pushes", "clearance_nm", "push_depth_nm", "approach_nm", "wire_tolerance_nm", "wire_step_nm",
                       "cuts"});
    p.tolerance_nm = r.num(n, k, "tolerance_nm", &d.tolerance_nm);
    p.speed_nm_per_s = r.num(n, k, "speed_nm_per_s", &d.speed_nm_per_s);
    p.travel_speed_nm_per_s = r.num(n, k, "travel_speed_nm_per_s", &d.travel_speed_nm_per_s);
    p.scan_size_nm = r.num(n, k, "scan_size_nm", &d.scan_size_nm);
    const double px_d = d.scan_px, mp_d = d.max_pushes;
    const double px = r.num(n, k, "scan_px", &px_d);
    p.scan_px = static_cast<int>(px);
    p.scan_s = r.num(n, k, "scan_s", &d.scan_s);
    const double mp = r.num(n, k, "max_pushes", &mp_d);
    p.max_pushes = static_cast<int>(mp);
    p.clearance_nm = r.num(n, k, "clearance_nm", &d.clearance_nm);
    p.push_depth_nm = r.num(n, k, "push_depth_nm", &d.push_depth_nm);
    p.approach_nm = r.num(n, k, "approach_nm", &d.approach_nm);
    p.wire_tolerance_nm = r.num(n, k, "wire_tolerance_nm", &d.wire_tolerance_nm);
    p.wire_step_nm = r.num(n, k, "wire_step_nm", &d.wire_step_nm);
    read_plan_cuts(r, n["cuts"], s);
}

// What the planner needs and excludes, checked once the whole scene is read.
void check_plan(const Reader &r, const Scene &s)
{
    if (!s.op.plan.enabled) {
        if (s.targets.any() && s.op.mode != "env") r.fail("objects.targets", "targets are for the planner: give operator.plan as well (or operator.mode: env)");
        if (!s.wire_targets.empty()) r.fail("objects.wire_targets", "targets are for the planner: give operator.plan as well");
        const double most = std::max(s.op.load_nN, s.op.load_ramp_to_nN.value_or(0.0));
        if (s.op.haptic.load_span_nN > 0 && most > s.op.haptic.load_span_nN)
            r.fail("operator.haptic.load_span_nN", "the hand presses the stylus to at most its stop, " +
                                                       Reader::show(YAML::Node(s.op.haptic.load_span_nN)) +
                                                       " nN, but the script asks for " + Reader::show(YAML::Node(most)) + " nN");
        return;
    }
    if (!s.targets.any() && s.wire_targets.empty() && s.op.plan.cuts.empty())
        r.fail("operator.plan", "the planner needs objects.targets (particles), objects.wire_targets (rods) or operator.plan.cuts");
    if (!s.op.local_scans.empty())
        r.fail("operator.local_scans", "the planner takes its own local scans: drop operator.local_scans with operator.plan");
    if (!s.op.cantilever_changes.empty())
        r.fail("operator.cantilever_changes", "not supported with operator.plan");
    if (s.op.haptic.load_span_nN > 0)
        r.fail("operator.haptic.load_span_nN", "the planner sets the load itself: drop the stylus's z axis with operator.plan");
    if (s.op.mode != "script") r.fail("operator.mode", "the planner drives the hand: drop operator.mode with operator.plan");
}

// operator: the scripted hand (path, load, local scans, lever changes), the
// haptic device and hand, and the planner.
void read_operator(const Reader &r, const YAML::Node &root, Scene &s)
{
    const Scene d;  // defaults
    YAML::Node op = root["operator"];
    if (!op.IsDefined()) r.fail("operator", "required value is missing");
    r.only_keys(op, "operator", {"load_nN", "speed_nm_per_s", "path_nm", "kappa", "local_scans", "cantilever_changes", "mode",
                                 "feel_threshold_N", "haptic", "hand", "plan", "scan_load_nN", "load_ramp_to_nN"});
    s.op.load_nN = r.num(op, "operator", "load_nN", &d.op.load_nN);
    if (op["load_ramp_to_nN"].IsDefined() && !op["load_ramp_to_nN"].IsNull())
        s.op.load_ramp_to_nN = r.num(op, "operator", "load_ramp_to_nN", nullptr);
    if (op["scan_load_nN"].IsDefined() && !op["scan_load_nN"].IsNull())
        s.op.scan_load_nN = r.num(op, "operator", "scan_load_nN", nullptr);
    s.op.speed_nm_per_s = r.num(op, "operator", "speed_nm_per_s", &d.op.speed_nm_per_s);
    s.op.kappa = r.num(op, "operator", "kappa", &d.op.kappa);
    s.op.mode = r.str(op, "operator", "mode", &d.op.mode, {"script", "feel", "browser", "env"});
    if (s.op.mode == "browser" && s.time_mode != "realtime")
        r.fail("operator.mode", "browser: a person's hand is paced by the wall clock: give time_mode: realtime");
    if (s.op.mode == "env" && s.time_mode == "realtime")
        r.fail("operator.mode", "env: a program's steps wait for each other in lockstep: leave time_mode out (docs/env.md)");
    s.op.feel_threshold_N = r.num(op, "operator", "feel_threshold_N", &d.op.feel_threshold_N);
    read_haptic(r, op, s);
    read_plan(r, op, s);
    YAML::Node path_n = op["path_nm"];
    if (!path_n.IsDefined() || path_n.IsNull()) {
        if (!s.op.plan.enabled && s.op.mode != "env") r.fail("operator.path_nm", "required value is missing");
        path_n = YAML::Node(YAML::NodeType::Sequence);
        YAML::Node c(YAML::NodeType::Sequence);
        c.push_back(s.field_center_nm.x);
        c.push_back(s.field_center_nm.y);
        path_n.push_back(c);
    }
    if (!path_n.IsSequence() || path_n.size() < 1)
        r.fail("operator.path_nm", "must be a list of [x, y] waypoints, got " + Reader::show(path_n));
    const double reach = s.op.kappa * s.field_nm / 2;
    for (std::size_t i = 0; i < path_n.size(); ++i) {
        const std::string key = "operator.path_nm[" + std::to_string(i) + "]";
        Vec2 v = r.vec2(path_n[i], key);
        if (std::fabs(v.x - s.field_center_nm.x) > reach || std::fabs(v.y - s.field_center_nm.y) > reach)
            r.fail(key, "waypoint " + Reader::show(path_n[i]) + " is outside the joystick's reach (kappa * field_nm / 2 around the field centre)");
        s.op.path_nm.push_back(v);
    }
    YAML::Node ls_n = op["local_scans"];
    if (ls_n.IsDefined() && !ls_n.IsNull()) {
        if (!ls_n.IsSequence()) r.fail("operator.local_scans", "must be a list, got " + Reader::show(ls_n));
        for (std::size_t i = 0; i < ls_n.size(); ++i) {
            const std::string key = "operator.local_scans[" + std::to_string(i) + "]";
            r.only_keys(ls_n[i], key, {"at_s", "around_id", "size_nm", "fix"});
            LocalScanSpec ls;
            ls.at_s = r.num(ls_n[i], key, "at_s", nullptr);
            const double id = r.num(ls_n[i], key, "around_id", nullptr);
            ls.around_id = static_cast<int>(id);
            bool known = false;
            for (const auto &p : s.particles) known = known || p.id == ls.around_id;
            for (const auto &m : s.landmarks) known = known || m.id == ls.around_id;
            if (!known) r.fail(key + ".around_id", "names no particle or landmark of objects, got " + Reader::show(ls_n[i]["around_id"]));
            const double size_d = 400;
            ls.size_nm = r.num(ls_n[i], key, "size_nm", &size_d);
            const std::string drift = "drift";
            ls.place = r.str(ls_n[i], key, "fix", &drift, {"drift", "place"}) == "place";
            if (!s.op.local_scans.empty() && ls.at_s < s.op.local_scans.back().at_s)
                r.fail(key + ".at_s", "local scans must be in time order, got " + Reader::show(ls_n[i]["at_s"]));
            s.op.local_scans.push_back(ls);
        }
    }
    YAML::Node cc_n = op["cantilever_changes"];
    if (cc_n.IsDefined() && !cc_n.IsNull()) {
        if (!cc_n.IsSequence()) r.fail("operator.cantilever_changes", "must be a list, got " + Reader::show(cc_n));
        for (std::size_t i = 0; i < cc_n.size(); ++i) {
            const std::string key = "operator.cantilever_changes[" + std::to_string(i) + "]";
            r.only_keys(cc_n[i], key, {"at_s", "offset_nm"});
            CantileverChangeSpec cc;
            cc.at_s = r.num(cc_n[i], key, "at_s", nullptr);
            if (!cc_n[i]["offset_nm"].IsDefined()) r.fail(key + ".offset_nm", "required value is missing");
            cc.offset_nm = r.vec2(cc_n[i]["offset_nm"], key + ".offset_nm");
            if (!s.op.cantilever_changes.empty() && cc.at_s < s.op.cantilever_changes.back().at_s)
                r.fail(key + ".at_s", "cantilever changes must be in time order, got " + Reader::show(cc_n[i]["at_s"]));
            s.op.cantilever_changes.push_back(cc);
        }
    }
}

// outputs: the display and the files a run writes.
void read_outputs(const Reader &r, const YAML::Node &root, Scene &s)
{
    YAML::Node out = root["outputs"];
    if (out.IsDefined() && !out.IsNull()) {
        r.only_keys(out, "outputs", {"image_px", "video", "png", "trails", "contact_sheet_frames", "update_mode"});
        const double px_d = s.out.image_px;
        const double px = r.num(out, "outputs", "image_px", &px_d);
        s.out.image_px = static_cast<int>(px);
        const std::string mp4 = "mp4";
        s.out.video = r.str(out, "outputs", "video", &mp4, {"mp4", "avi", "none"});
        s.out.png = r.boolean(out, "outputs", "png", true);
        s.out.trails = r.boolean(out, "outputs", "trails", false);
        const double csf = 16;
        const double sheet = r.num(out, "outputs", "contact_sheet_frames", &csf);
        s.out.contact_sheet_frames = static_cast<int>(sheet);
        const std::string local = "local";
        s.out.update_mode = r.str(out, "outputs", "update_mode", &local, {"local", "full"});
    }
}

// expect: the checks of the run's verdict this scene fails on purpose.
void read_expect(const Reader &r, const YAML::Node &root, Scene &s)
{
    const YAML::Node e = root["expect"];
    if (!e.IsDefined() || e.IsNull()) return;
    if (!e.IsSequence()) r.fail("expect", "must be a list of the run's checks, got " + Reader::show(e));
    const auto &known = verdict_checks();
    for (std::size_t i = 0; i < e.size(); ++i) {
        const std::string k = "expect[" + std::to_string(i) + "]";
        if (!e[i].IsScalar() || std::find(known.begin(), known.end(), e[i].Scalar()) == known.end()) {
            std::string list;
            for (const auto &n : known) list += (list.empty() ? "" : ", ") + n;
            r.fail(k, "unknown check " + Reader::show(e[i]) + " (known: " + list + ")");
        }
        if (std::find(s.expect.begin(), s.expect.end(), e[i].Scalar()) != s.expect.end())
            r.fail(k, "check " + Reader::show(e[i]) + " is listed twice");
        s.expect.push_back(e[i].Scalar());
    }
}

}  // namespace afm::scene_detail
