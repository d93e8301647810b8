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
#include "aside.hpp"
#include "pattern.hpp"
#include "run_process.hpp"

namespace {

// The operator's command line and its one check of each option (command_line.hpp).
struct Options {
    std::string scene_path, out_dir;
    bool check_targets = false;
};

const afm::Process<Options> kProcess = {
    {"operator",
    "usage: operator --scene FILE [--out DIR]\n"
    "       operator --scene FILE --check-targets\n"
    "  The operator: a scripted hand on a haptic device, or the planner (operator.plan);\n"
    "  normally started by ./afm run inside the run's namespace.\n",
    {
        {{"--scene", "FILE", nullptr, nullptr, true}, afm::cli::text(&Options::scene_path)},
        {{"--out", "DIR", "options:", "write DIR/operator_report.json at the end"}, afm::cli::text(&Options::out_dir)},
        {{"--check-targets", nullptr, "options:",
          "only say whether the planner can serve the scene's targets\n"
          "(pattern.hpp: sites inside the field, no more than the particles, far\n"
          "enough apart); exit 0 if it can (or the scene does not plan), 2 naming\n"
          "the problem. afm_launch asks this before a planning run starts, so that\n"
          "it need not load OpenCV itself."},
         afm::cli::flag(&Options::check_targets)},
    }},
    {AFM_CH_HAPTIC_FORCE, AFM_CH_AFM_HEARTBEAT, AFM_CH_FW_STATE, AFM_CH_AFM_SCAN_LINE},
    {AFM_CH_HAPTIC_POSE, AFM_CH_AFM_SCAN_REQ, AFM_CH_HOST_OBJECT_FIX},
    [](const Options &o) { return o.out_dir.empty() || o.check_targets ? std::string() : o.out_dir + "/operator_report.json"; }};

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
static void serve(afm::Operator &op, afm::Planner *planner, afm::PlannerTurns &turns, afm::Inbox &inbox, afm::Lifecycle &life)
{
    life.serve([&] { return afm::Progress{op.answered >= -1, op.answered, 0}; },
               [&](int ms) {
                   op.repeat_finished();
                   inbox.handle(op.have_force ? 0 : ms);
                   if (!op.have_force) return;
                   if (planner) op.answer_by_planner(turns);
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
    const auto report = life.report_from([&] { return afm::operator_report(op, planner.get(), scene, inbox.report()); });
    if (planner) plan_thread = start_planner(*planner, turns);
    serve(op, planner.get(), turns, inbox, life);
    turns.stop();
    if (plan_thread.joinable()) plan_thread.join();
    if (op.stroke) op.stroke->turns.stop();   // a stroke under way ends with the run (joined when op goes)
    if (planner && turns.error()) std::rethrow_exception(turns.error());
    life.done(op.answered, 0);
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
                return why.empty() ? afm::kExitOk : afm::kExitInput;
            }
            return operate(scene, life);
        } catch (const afm::PlanError &e) {   // the scene asks the planner for what it cannot do
            throw afm::InputError(std::string("operator: the planner: ") + e.what());
        }
    });
}
