// operator: the operator's side of the bench. For every haptic force it
// receives (block n) it answers with the stylus pose for block n + 1: where
// the stylus is at the end of block n (lockstep; the card asks for the
// first pose with a force of block -1).
//
// With a script (operator.path_nm, mode script or feel) a hand holds the
// stylus of a haptic device (haptic.hpp): it pulls the stylus towards the
// script's aim (hand_script.hpp) while the device pushes back with the force
// the card renders, the force of block n - 1 held over block n (the force of
// block n arrives at its end). With operator.plan the planner
// (planner.hpp) drives the pose itself, runs in its own thread in strict
// turns with this one, and takes its local scans and fixes through it.
#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <exception>
#include <mutex>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "afm/haptic_force_t.hpp"
#include "afm/haptic_pose_t.hpp"
#include "afm/heartbeat_t.hpp"
#include "afm/object_fix_t.hpp"
#include "afm/fw_state_t.hpp"
#include "afm/objects_t.hpp"
#include "afm/scan_line_t.hpp"
#include "aside.hpp"
#include "bus.hpp"
#include "card_setup.hpp"
#include "hand_script.hpp"
#include "inbox.hpp"
#include "haptic.hpp"
#include "pattern.hpp"
#include "objects_view.hpp"
#include "planner.hpp"
#include "process.hpp"
#include "scan_client.hpp"
#include "scene.hpp"

namespace {

const char *kUsage =
    "usage: operator --scene FILE [--out DIR]\n"
    "       operator --scene FILE --check-targets\n"
    "  The operator: a scripted hand on a haptic device, or the planner (operator.plan);\n"
    "  normally started by ./afm run inside the run's namespace.\n"
    "  --check-targets: only say whether the planner can serve the scene's targets\n"
    "      (pattern.hpp: sites inside the field, no more than the particles, far enough\n"
    "      apart); exit 0 if it can (or the scene does not plan), 2 naming the problem.\n"
    "      afm_launch asks this before a planning run starts, so that it need not\n"
    "      load OpenCV itself.\n";

constexpr int kScanReqBase = 10000;   // the planner's scans (the renderer's are below)
constexpr int kFixRetryMs = 200;
constexpr int kScanRetryMs = 300;
constexpr int kFinishedRepeatMs = 200;
constexpr double kPm_nm = 0.0015;       // the card holds positions in whole pm: a position it set is the asked one within this

// The planner's side of the turns: it blocks in each call until the bus
// side has served it; the bus side serves one request at a time.
class TurnBench : public afm::PlanBench {
public:
    enum class Req { None, Block, Scan, Fix, Done, Failed };

    // --- the planner's thread
    const afm::objects_t &block(const afm::PlanPose &p) override
    {
        std::unique_lock<std::mutex> lk(m_);
        pose_ = p;
        ask(lk, Req::Block);
        return model_;
    }
    cv::Mat scan(const afm::Field &f) override
    {
        std::unique_lock<std::mutex> lk(m_);
        field_ = f;
        ask(lk, Req::Scan);
        return scan_;
    }
    const afm::objects_t &fix(int id, afm::Vec2 at, bool place, std::string *note) override
    {
        std::unique_lock<std::mutex> lk(m_);
        fix_id_ = id;
        fix_at_ = at;
        fix_place_ = place;
        ask(lk, Req::Fix);
        *note = note_;
        return model_;
    }
    double time_s() const override { return t_s_; }
    void finish(std::exception_ptr e)
    {
        std::lock_guard<std::mutex> lk(m_);
        req_ = e ? Req::Failed : Req::Done;
        error_ = e;
        cv_.notify_all();
    }

    // --- the bus side
    // Waits (up to wait_ms) for the planner's next request; Req::None if none yet.
    Req next(int wait_ms)
    {
        std::unique_lock<std::mutex> lk(m_);
        cv_.wait_for(lk, std::chrono::milliseconds(wait_ms), [&] { return req_ != Req::None; });
        return req_;
    }
    // Answers the request being served (the model after it, the scan) and
    // lets the planner go on.
    void answer(const afm::objects_t &model, double t_s, const cv::Mat *scan = nullptr, const std::string &note = "")
    {
        std::lock_guard<std::mutex> lk(m_);
        model_ = model;
        t_s_ = t_s;
        if (scan) scan_ = scan->clone();
        note_ = note;
        req_ = Req::None;
        cv_.notify_all();
    }
    void stop()
    {
        std::lock_guard<std::mutex> lk(m_);
        stop_ = true;
        cv_.notify_all();
    }
    afm::PlanPose pose() const { return pose_; }
    afm::Field field() const { return field_; }
    int fix_object() const { return fix_id_; }
    afm::Vec2 fix_at() const { return fix_at_; }
    bool fix_place() const { return fix_place_; }
    std::exception_ptr error()
    {
        std::lock_guard<std::mutex> lk(m_);
        return error_;
    }

private:
    void ask(std::unique_lock<std::mutex> &lk, Req r)
    {
        if (stop_) throw afm::PlanStopped{};
        req_ = r;
        cv_.notify_all();
        cv_.wait(lk, [&] { return req_ == Req::None || stop_; });
        if (stop_) throw afm::PlanStopped{};
    }

    std::mutex m_;
    std::condition_variable cv_;
    Req req_ = Req::None;
    bool stop_ = false;
    afm::PlanPose pose_;
    afm::Field field_{};
    int fix_id_ = 0;
    afm::Vec2 fix_at_;
    bool fix_place_ = false;
    afm::objects_t model_;
    double t_s_ = 0;
    cv::Mat scan_;
    std::string note_;
    std::exception_ptr error_;
};

struct Operator {
    const afm::Scene &scene;
    lcm::LCM &lc;
    afm::Inbox *inbox = nullptr;     // the process's inbox, once made (main)
    afm::Heartbeat hb;
    int64_t answered = -2;   // last haptic force answered (-1: the card's request for pose 0)
    afm::haptic_pose_t last{};
    bool sim_done = false;
    bool have_force = false;
    afm::haptic_force_t force{};     // the force to answer (seq answered + 1)
    double peak_force_N = 0;
    int64_t forces = 0;
    // the script's hand on the device
    afm::HandScript script;
    afm::HapticLoop device;
    afm::Vec2 held_N;                 // the force the device renders over the block being integrated
    double reach_nm;                  // apex travel for the joystick's +-1
    double half_range_m;
    double peak_speed_m_per_s = 0;
    // the planner
    afm::ObjectsView view;            // FW_STATE's objects, whole: view.whole() the latest set (highest seq, then fix id)
    afm::ScanClient scan;
    int scans = 0, fixes_sent = 0;
    bool plan_done = false;
    int64_t finished_seq = -1;       // the block whose force the planner finished on
    bool ending_seen = false;        // the simulator said the run ends
    std::chrono::steady_clock::time_point finished_sent;
    afm::PlanPose hold_pose;

    Operator(const afm::Scene &s, lcm::LCM &l)
        : scene(s), lc(l), hb(l, "operator"), script(s),
          device(s.op.haptic, s.op.hand, 1.0 / s.block_hz, to_stylus(s, s.start_nm())), reach_nm(s.op.kappa * s.field_nm / 2),
          half_range_m(s.op.haptic.half_range_mm * 1e-3), scan(l)
    {
    }

    static afm::Vec2 to_stylus(const afm::Scene &s, afm::Vec2 p_nm)
    {
        const double reach = s.op.kappa * s.field_nm / 2, r = s.op.haptic.half_range_mm * 1e-3;
        return {(p_nm.x - s.field_center_nm.x) / reach * r, (p_nm.y - s.field_center_nm.y) / reach * r};
    }

    afm::Reject on_force(const afm::haptic_force_t &f)
    {
        if (f.seq == answered) {      // resent force: our pose was lost
            lc.publish(AFM_CH_HAPTIC_POSE, &last);
            return afm::Reject::none;
        }
        if (f.seq < answered) return afm::Reject::seq_past;
        if (f.seq > answered + 1) return afm::Reject::seq_future;
        if (have_force) return afm::Reject::none;   // the same force again, not yet answered
        force = f;
        have_force = true;
        return afm::Reject::none;
    }

    // FW_STATE n comes with HAPTIC_FORCE n: one from further ahead than
    // the next force cannot have been sent yet (taking it would make every
    // later message look old). The planner reads its objects.
    afm::Reject on_state(const afm::fw_state_t &s)
    {
        const afm::objects_t &m = s.objects;
        if (m.seq > answered + 2) return afm::Reject::seq_future;
        if (view.ready() && afm::key_of(m) <= afm::key_of(view.whole())) return afm::Reject::seq_past;
        // held: before its base, taken when that comes
        return view.apply(m) == afm::ObjectsView::Take::refused ? afm::Reject::out_of_range : afm::Reject::none;
    }

    afm::Reject on_line(const afm::scan_line_t &m)
    {
        scan.on_line(m);   // lines of another client's scan are not ours to count
        return afm::Reject::none;
    }

    afm::Reject on_heartbeat(const afm::heartbeat_t &m)
    {
        if (afm::run_over(m)) sim_done = true;
        if (afm::says(m, "sim_afm", afm::RunState::ending)) ending_seen = true;
        return afm::Reject::none;
    }

    // The planner's "finished", again until the simulator says the run ends.
    void repeat_finished()
    {
        if (!plan_done || ending_seen || finished_seq < 0) return;
        if (std::chrono::steady_clock::now() - finished_sent < std::chrono::milliseconds(kFinishedRepeatMs)) return;
        hb.send(afm::RunState::finished, finished_seq, afm::block_end_utime(scene, finished_seq));
        finished_sent = std::chrono::steady_clock::now();
    }

    void publish_pose(afm::Vec2 joy, bool engaged, double load_nN = 0)
    {
        const int64_t n = force.seq;
        last.utime = afm::block_end_utime(scene, n);
        last.seq = n + 1;
        last.joy[0] = std::clamp(joy.x, -1.0, 1.0);
        last.joy[1] = std::clamp(joy.y, -1.0, 1.0);
        last.joy[2] = 0;
        last.load_nN = load_nN > 0 ? load_nN : scene.op.load_nN;
        last.engaged = engaged;
        answered = n;
        have_force = false;
        lc.publish(AFM_CH_HAPTIC_POSE, &last);
        hb.maybe_send(afm::RunState::running, n, last.utime);
    }

    void count_force()
    {
        peak_force_N = std::max(peak_force_N, std::hypot(force.force_N[0], force.force_N[1]));
        ++forces;
    }

    // The hand on the device: block n integrated with the force of block
    // n - 1, the pose for n + 1 is where the stylus ends.
    void answer_by_hand()
    {
        count_force();
        const afm::Vec2 aim_nm = script.advance(1.0 / scene.block_hz, held_N);
        device.step(to_stylus(scene, aim_nm), held_N);
        held_N = {force.force_N[0], force.force_N[1]};
        const afm::Vec2 x = device.position_m(), v = device.velocity_m_per_s();
        peak_speed_m_per_s = std::max(peak_speed_m_per_s, std::hypot(v.x, v.y));
        publish_pose({x.x / half_range_m, x.y / half_range_m}, true);
    }

    // The joystick for an apex target in frame A: the card moves the
    // joystick's workspace with the drift it knows (fw_card), so the pose
    // is the target in the sample's coordinates.
    afm::Vec2 joy_of(afm::Vec2 tip_nm) const
    {
        const double dx = view.ready() ? view.whole().drift_nm[0] : 0.0, dy = view.ready() ? view.whole().drift_nm[1] : 0.0;
        return {(tip_nm.x - dx - scene.field_center_nm.x) / reach_nm, (tip_nm.y - dy - scene.field_center_nm.y) / reach_nm};
    }

    // Handles the bus until `done` or the run ends.
    template <class F> bool pump_until(F done, void (Operator::*retry)() = nullptr)
    {
        while (!done()) {
            if (sim_done) return false;
            inbox->handle(20);
            if (retry) (this->*retry)();
        }
        return true;
    }

    void retry_scan() { scan.retry(kScanRetryMs); }

    // Serves the planner until it hands over the pose for block n + 1.
    void answer_by_planner(TurnBench &bench)
    {
        count_force();
        const int64_t n = force.seq;
        if (n >= 0 && !plan_done) {
            if (!pump_until([&] { return view.ready() && view.whole().seq >= n; })) return;
            bench.answer(view.whole(), afm::block_end_utime(scene, n) * 1e-6);
        }
        while (!plan_done) {
            const TurnBench::Req r = bench.next(50);
            if (r == TurnBench::Req::None) {
                while (inbox->handle(0) > 0) {}   // all that came: the socket is the only queue
                if (sim_done) return;
                continue;
            }
            if (r == TurnBench::Req::Block) {
                hold_pose = bench.pose();
                publish_pose(joy_of(hold_pose.tip_nm), hold_pose.engaged, hold_pose.load_nN);
                return;
            }
            if (r == TurnBench::Req::Scan) {
                const afm::Field f = bench.field();
                afm::ScanRegion reg{f.x0_nm, f.y0_nm, f.size_nm, f.size_nm, f.px, f.px};
                scan.start(kScanReqBase + ++scans, reg, n + 1);   // the sample as the simulator holds it after block n + 1
                if (!pump_until([&] { return !scan.busy(); }, &Operator::retry_scan)) return;
                bench.answer(view.whole(), afm::block_end_utime(scene, n) * 1e-6, &scan.heights());
                continue;
            }
            if (r == TurnBench::Req::Fix) {
                if (!send_fix(bench)) return;
                continue;
            }
            plan_done = true;   // Done or Failed
            finished_seq = n;
            hb.send(afm::RunState::finished, n, afm::block_end_utime(scene, n));   // the simulator ends the run soon after (before the pose)
            finished_sent = std::chrono::steady_clock::now();
        }
        publish_pose(joy_of(hold_pose.tip_nm), false);
    }

    // A fix, until the card acknowledges it; the note says if it refused.
    bool send_fix(TurnBench &bench)
    {
        afm::object_fix_t f{};
        f.utime = afm::block_end_utime(scene, force.seq);
        f.fix_id = ++fixes_sent;
        f.object_id = bench.fix_object();
        f.scan_x_nm = bench.fix_at().x;
        f.scan_y_nm = bench.fix_at().y;
        f.kind = bench.fix_place() ? afm::object_fix_t::KIND_PLACE : afm::object_fix_t::KIND_DRIFT;
        auto sent = std::chrono::steady_clock::now();
        lc.publish(AFM_CH_HOST_OBJECT_FIX, &f);
        const bool ok = pump_until([&] {
            if (view.whole().fix_id >= f.fix_id) return true;
            if (std::chrono::steady_clock::now() - sent > std::chrono::milliseconds(kFixRetryMs)) {
                lc.publish(AFM_CH_HOST_OBJECT_FIX, &f);
                sent = std::chrono::steady_clock::now();
            }
            return false;
        });
        if (!ok) return false;
        // The card's answer is its model: a fix it applied (drift or place)
        // leaves that particle where the scan found it, to the pm.
        bool applied = false;
        for (const auto &p : view.whole().particles)
            if (p.id == f.object_id) applied = std::fabs(p.x_nm - f.scan_x_nm) <= kPm_nm && std::fabs(p.y_nm - f.scan_y_nm) <= kPm_nm;
        bench.answer(view.whole(), afm::block_end_utime(scene, force.seq) * 1e-6, nullptr, applied ? "" : "refused: beyond the firmware's limit");
        return true;
    }
};

nlohmann::json plan_json(const afm::Planner &p)
{
    using nlohmann::json;
    const afm::PlanReport &r = p.report();
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

// operator_report.json: what the operator did (the hand's device and the
// contacts it felt, or the planner's account).
void write_report(const Operator &op, const afm::Planner *planner, const afm::Scene &scene, const std::string &out_dir,
                  const afm::Rejections &rejected)
{
    nlohmann::json rep = {{"poses", op.forces}, {"peak_haptic_force_N", op.peak_force_N}, {"rejected", rejected.to_json()}};
    if (planner) {
        rep["plan"] = plan_json(*planner);
    } else {
        const afm::CardSetup card(scene);
        const afm::HapticBound b = afm::haptic_bound(scene, card.config());
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
                         {"peak_stylus_speed_m_per_s", op.peak_speed_m_per_s},
                         {"device_damping_Ns_per_m", scene.op.haptic.damping_Ns_per_m},
                         {"hand", {{"stiffness_N_per_m", scene.op.hand.stiffness_N_per_m},
                                   {"damping_Ns_per_m", scene.op.hand.damping_Ns_per_m},
                                   {"mass_kg", scene.op.hand.mass_kg}}}};
        nlohmann::json contacts = nlohmann::json::array();
        for (const auto &c : op.script.contacts())
            contacts.push_back({{"t_s", c.t_s}, {"aim_nm", {c.aim_nm.x, c.aim_nm.y}}, {"force_N", c.force_N}, {"stroke", c.stroke}});
        rep["contacts_felt"] = contacts;
    }
    afm::write_report(out_dir + "/operator_report.json", rep);
}

}  // namespace

int main(int argc, char **argv)
{
    std::string scene_path, out_dir;
    bool check_targets = false;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--scene" && i + 1 < argc) scene_path = argv[++i];
        else if (a == "--out" && i + 1 < argc) out_dir = argv[++i];
        else if (a == "--check-targets") check_targets = true;
        else if (a == "-h" || a == "--help") { std::fputs(kUsage, stdout); return 0; }
        else { std::fprintf(stderr, "operator: unknown argument '%s'\n%s", a.c_str(), kUsage); return 2; }
    }
    if (scene_path.empty()) { std::fputs(kUsage, stderr); return afm::kExitInput; }
    return afm::run_process("operator", [&] {
      try {
        const afm::Scene scene = afm::load_scene(scene_path);
        if (check_targets) {
            const std::string why = scene.op.plan.enabled ? afm::targets_refusal(scene) : "";
            if (!why.empty()) std::fprintf(stderr, "%s\n", why.c_str());
            return why.empty() ? afm::kExitOk : afm::kExitInput;
        }
        std::unique_ptr<afm::Planner> planner;
        if (scene.op.plan.enabled) planner = std::make_unique<afm::Planner>(scene);
        auto lc = afm::open_bus();
        Operator op(scene, *lc);
        afm::Inbox inbox(lc.get());
        op.inbox = &inbox;
        inbox.on<afm::haptic_force_t>(AFM_CH_HAPTIC_FORCE, [&](const afm::haptic_force_t &m) { return op.on_force(m); });
        inbox.on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [&](const afm::heartbeat_t &m) { return op.on_heartbeat(m); });
        TurnBench bench;
        std::thread plan_thread;
        struct Joiner {   // the planner's thread ends with the run, however main leaves
            TurnBench &b;
            std::thread &t;
            ~Joiner()
            {
                b.stop();
                if (t.joinable()) t.join();
            }
        } joiner{bench, plan_thread};
        if (planner) {
            inbox.on<afm::fw_state_t>(AFM_CH_FW_STATE, [&](const afm::fw_state_t &s) { return op.on_state(s); });
            inbox.on<afm::scan_line_t>(AFM_CH_AFM_SCAN_LINE, [&](const afm::scan_line_t &m) { return op.on_line(m); });
            op.hold_pose = {scene.start_nm(), false};
        }
        afm::check_lockstep_reads(scene, inbox.channels(), "operator");
        if (planner) {
            plan_thread = std::thread([&] {
                try {
                    planner->run(bench);
                    bench.finish(nullptr);
                } catch (const afm::PlanStopped &) {
                } catch (...) {
                    bench.finish(std::current_exception());
                }
            });
        }
        while (!op.sim_done) {
            op.hb.maybe_send(op.answered < -1 ? afm::RunState::ready : afm::RunState::running, op.answered, 0);
            op.repeat_finished();
            inbox.handle(op.have_force ? 0 : op.answered < -1 ? afm::kReadyPeriodMs : 100);
            if (!op.have_force) continue;
            if (planner) op.answer_by_planner(bench);
            else op.answer_by_hand();
            if (planner && bench.error()) std::rethrow_exception(bench.error());
        }
        bench.stop();
        if (plan_thread.joinable()) plan_thread.join();
        if (planner && bench.error()) std::rethrow_exception(bench.error());
        if (!out_dir.empty()) write_report(op, planner.get(), scene, out_dir, inbox.rejected());
        op.hb.send(afm::RunState::done, op.answered, 0);
        return afm::kExitOk;
      } catch (const afm::PlanError &e) {   // the scene asks the planner for what it cannot do
        throw afm::InputError(std::string("operator: the planner: ") + e.what());
      }
    });
}
