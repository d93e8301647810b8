// operator: the operator's process (operator.hpp: the Operator, its hand or
// its planner and their turns). Reads the command line, then serves the bus
// until the run is over, and writes operator_report.json.
#include <cstdio>
#include <exception>
#include <memory>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "operator.hpp"
#include "env_input.hpp"
#include "aside.hpp"
#include "pattern.hpp"
#include "plan_estimate.hpp"
#include "run_process.hpp"

namespace {

// The operator's command line and its one check of each option (command_line.hpp).
struct Options {
    std::string scene_path, out_dir;
    bool check_targets = false;
    bool plan_jobs = false;
};

const afm::Process<Options> kProcess = {
    {"operator",
    "usage: operator --scene FILE [--out DIR]\n"
    "       operator --scene FILE --check-targets\n"
    "       operator --scene FILE --plan-jobs\n"
    "  The operator: a scripted hand on a haptic device, or the planner (operator.plan);\n"
    "  normally started by ./afm run inside the run's namespace.\n",
    {
        {{"--scene", "FILE", nullptr, nullptr, true}, afm::cli::text(&Options::scene_path)},
        {{"--out", "DIR", "options:", "write DIR/operator_report.json at the end"}, afm::cli::text(&Options::out_dir)},
        {{"--check-targets", nullptr, "options:",
          "only say whether the planner can serve the scene's targets\n"
          "(pattern.hpp: sites inside the field, no more than the particles, far\n"
          "enough apart); exit 0 if it can (or the scene does not plan), 2 naming\n"
          "the problem; if it can, the plan's simulated time, estimated\n"
          "(plan_estimate.hpp), as one JSON line on stdout. afm_launch asks this\n"
          "before a planning run starts, so that it need not load OpenCV itself."},
         afm::cli::flag(&Options::check_targets)},
        {{"--plan-jobs", nullptr, "options:",
          "only print, as JSON, the planner's jobs from the scene's particles:\n"
          "each site's particle in the order the planner takes them up\n"
          "(Planner::jobs); the built-in policy of analysis.env asks this\n"
          "(docs/env.md)."},
         afm::cli::flag(&Options::plan_jobs)},
    }},
    {AFM_CH_HAPTIC_FORCE, AFM_CH_AFM_HEARTBEAT, AFM_CH_FW_STATE, AFM_CH_AFM_SCAN_LINE},
    {AFM_CH_HAPTIC_POSE, AFM_CH_AFM_SCAN_REQ, AFM_CH_HOST_OBJECT_FIX},
    [](const Options &o) { return o.out_dir.empty() || o.check_targets || o.plan_jobs ? std::string() : o.out_dir + "/operator_report.json"; }};

}  // namespace

// The planner on a thread of its own, turn by turn with the bus (PlannerTurns):
// its end, or its error, is handed to the turns (finish), where the bus side reads it.
static std::thread start_planner(afm::Planner &planner, afm::PlannerTurns &turns)
{
    return std::thread([&planner, &turns] {
        try {
            planner.run(turns);
            turns.finish(nullptr);
        } catch (const afm::PlanStopped &) {
        } catch (...) {
            turns.finish(std::current_exception());
        }
    });
}

// The operator's turns until the run is over: each force answered, by the
// planner or by the hand.
static void serve(afm::Operator &op, afm::Planner *planner, afm::EnvDriver *env, afm::PlannerTurns &turns, afm::Inbox &inbox,
                  afm::Lifecycle &life)
{
    life.serve([&] { return afm::Progress{op.answered >= -1, op.answered, 0}; },
               [&](int ms) {
                   op.repeat_finished();
                   inbox.handle(op.have_force ? 0 : ms);
                   if (!op.have_force) return;
                   if (planner) op.answer_by_planner(turns);
                   else if (env) env->answer();
                   else op.answer_by_hand();
                   if (planner && turns.error()) std::rethrow_exception(turns.error());
               },
               [&] { return op.sim_done; });
}

// The operator on the bus, once its scene is read.
static int operate(const afm::Scene &scene, afm::Lifecycle &life)
{
    std::unique_ptr<afm::Planner> planner;
    if (scene.op.plan.enabled) planner = std::make_unique<afm::Planner>(scene);
    afm::Operator op(scene, life.bus(), life.heartbeat());
    if (scene.op.mode == "browser") {   // the hand from the page (docs/view.md); the page's server hears this
        op.page = std::make_unique<afm::HandInput>(scene, afm::HandInput::open_from_env());
        op.stroke_planner = std::make_unique<afm::Planner>(scene);   // the strokes the page asks for (PUSH)
        life.starting("hand: browser load_nN=" + std::to_string(scene.op.load_nN), op.answered);
    }
    std::unique_ptr<afm::EnvDriver> env;   // operator.mode env: a program's actions (env_input.hpp; it makes op.page)
    if (scene.op.mode == "env") env = std::make_unique<afm::EnvDriver>(op, afm::EnvDriver::open_from_env());
    afm::Inbox inbox(&life.bus());
    op.inbox = &inbox;
    inbox.on<afm::haptic_force_t>(AFM_CH_HAPTIC_FORCE, [&](const afm::haptic_force_t &m) { return op.on_force(m); });
    inbox.on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [&](const afm::heartbeat_t &m) { return op.on_heartbeat(m); });
    afm::PlannerTurns turns;
    std::thread plan_thread;
    struct Joiner {   // the planner's thread ends with the run, however main leaves
        afm::PlannerTurns &b;
        std::thread &t;
        ~Joiner()
        {
            b.stop();
            if (t.joinable()) t.join();
        }
    } joiner{turns, plan_thread};
    if (planner) {
        inbox.on<afm::fw_state_t>(AFM_CH_FW_STATE, [&](const afm::fw_state_t &s) { return op.on_state(s); });
        inbox.on<afm::scan_line_t>(AFM_CH_AFM_SCAN_LINE, [&](const afm::scan_line_t &m) { return op.on_line(m); });
        op.hold_pose = {scene.start_nm(), false};
    }
    if (op.page) {   // the local scans the person asks for (Operator::page_scan), the strokes' model and scans
        inbox.on<afm::fw_state_t>(AFM_CH_FW_STATE, [&](const afm::fw_state_t &s) { return op.on_state(s); });
        inbox.on<afm::scan_line_t>(AFM_CH_AFM_SCAN_LINE, [&](const afm::scan_line_t &m) { return op.on_line(m); });
    }
    afm::check_lockstep_reads(scene, inbox.channels(), "operator");
    life.check_subscriptions(inbox.channels());
    const auto report = life.report_from([&] {
        nlohmann::json r = afm::operator_report(op, planner.get(), scene, inbox.report());
        if (env) r["env"] = env->report();
        return r;
    });
    if (planner) plan_thread = start_planner(*planner, turns);
    serve(op, planner.get(), env.get(), turns, inbox, life);
    turns.stop();
    if (plan_thread.joinable()) plan_thread.join();
    if (op.stroke) op.stroke->turns.stop();   // a stroke under way ends with the run (joined when op goes)
    if (planner && turns.error()) std::rethrow_exception(turns.error());
    life.done(op.answered, 0);
    return afm::kExitOk;
}

// --plan-jobs: the planner's jobs from the scene's particles, as JSON on stdout.
static int print_jobs(const afm::Scene &scene)
{
    afm::objects_t m{};
    for (const auto &p : scene.particles) m.particles.push_back({p.id, p.x_nm, p.y_nm, p.radius_nm, false});
    m.n_particles = static_cast<int32_t>(m.particles.size());
    const afm::Planner planner(scene);
    nlohmann::json out = nlohmann::json::array();
    for (const afm::PlanJob &j : planner.jobs(m)) {
        const afm::Vec2 at = planner.sites()[static_cast<std::size_t>(j.site)];
        out.push_back({{"site", j.site}, {"site_nm", {at.x, at.y}}, {"particle", j.particle}});
    }
    std::printf("%s\n", nlohmann::json{{"jobs", out}}.dump().c_str());
    return afm::kExitOk;
}

int main(int argc, char **argv)
{
    return afm::run_process(kProcess, argc, argv, [](const Options &opt, afm::Lifecycle &life) -> int {
        try {
            const afm::Scene scene = afm::load_scene(opt.scene_path);
            if (opt.check_targets) {
                const std::string why = scene.op.plan.enabled ? afm::targets_refusal(scene) : "";
                if (!why.empty()) std::fprintf(stderr, "%s\n", why.c_str());
                else if (scene.op.plan.enabled) std::printf("%s\n", afm::plan_estimate_json(afm::estimate_plan(scene)).dump().c_str());
                return why.empty() ? afm::kExitOk : afm::kExitInput;
            }
            if (opt.plan_jobs) return print_jobs(scene);
            return operate(scene, life);
        } catch (const afm::PlanError &e) {   // the scene asks the planner for what it cannot do
            throw afm::InputError(std::string("operator: the planner: ") + e.what());
        }
    });
}
