// Operator: the operator's side of the loop (operator/main.cpp runs it). For every haptic force it
// receives (block n) it answers with the stylus pose for block n + 1: where
// the stylus is at the end of block n (lockstep; the card asks for the
// first pose with a force of block -1).
//
// With a script (operator.path_nm, mode script or feel) a hand holds the
// stylus of a haptic device (haptic_device.hpp): it pulls the stylus towards the
// script's aim (hand_script.hpp) while the device pushes back with the force
// the card renders, the force of block n - 1 held over block n (the force of
// block n arrives at its end). With operator.mode browser (time_mode
// realtime) the hand pulls the stylus towards the target a person sets on
// the page (hand_input.hpp) instead of a script's aim, with the load and
// the stylus button the page sets; a planner stroke the page asks for
// (PUSH, hand_input.hpp) takes the tip from the hand while it runs
// (Stroke, below). With operator.plan the planner
// (planner.hpp) drives the pose itself, runs in its own thread in strict
// turns with this one, and takes its local scans and fixes through it.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "afm/haptic_force_t.hpp"
#include "afm/haptic_pose_t.hpp"
#include "afm/heartbeat_t.hpp"
#include "afm/object_fix_t.hpp"
#include "afm/fw_state_t.hpp"
#include "afm/objects_t.hpp"
#include "afm/scan_line_t.hpp"
#include "bus.hpp"
#include "hand_input.hpp"
#include "hand_script.hpp"
#include "haptic_device.hpp"
#include "haptic_bound.hpp"
#include "inbox.hpp"
#include "objects_view.hpp"
#include "planner.hpp"
#include "process.hpp"
#include "scan_client.hpp"
#include "scan_dewarp.hpp"
#include "lockstep.hpp"
#include "scene.hpp"
#include "planner_turns.hpp"

namespace afm {

constexpr int kScanReqBase = 10000;   // the planner's scans (the renderer's are below)
constexpr int kFixRetryMs = 200;
constexpr int kScanRetryMs = 300;
constexpr int kFinishedRepeatMs = 200;
constexpr int kStrokeNewsMs = 500;      // a stroke's progress on the heartbeat, at most this often (wall)
constexpr double kPm_nm = 0.0015;       // the card holds positions in whole pm: a position it set is the asked one within this


// operator.mode browser: one planner stroke the page asked for (PUSH), the
// planner on a thread of its own in turns with the bus (PlannerTurns), as a
// planning run's; ended (stopped and joined) with this.
struct Stroke {
    HandInput::PushAsk ask{};
    PlannerTurns turns;
    std::thread thread;
    PlanItem item;              // the planner's account, once it has finished
    bool served_block = false;  // the pose of the block being answered came from the planner
    double started_s = 0;       // simulated time
    int pushes0 = 0, scans0 = 0;   // the planner's totals at its start
    std::chrono::steady_clock::time_point told;   // the page last told of its progress
    ~Stroke()
    {
        turns.stop();
        if (thread.joinable()) thread.join();
    }
};

struct StrokeDone {             // a stroke's account, for operator_report.json
    PlanItem item;
    Vec2 asked_nm;              // the target the page asked for (frame A)
    double started_s = 0, ended_s = 0;
};

struct Operator {
    const Scene &scene;
    lcm::LCM &lc;
    Inbox *inbox = nullptr;     // the process's inbox, once made (main)
    Heartbeat &hb;   // the process's one (its Lifecycle's)
    int64_t answered = -2;   // last haptic force answered (-1: the card's request for pose 0)
    haptic_pose_t last{};
    bool sim_done = false;
    bool have_force = false;
    haptic_force_t force{};     // the force to answer (seq answered + 1)
    double peak_force_N = 0;
    int64_t forces = 0;
    // the script's hand on the device
    HandScript script;
    std::unique_ptr<HandInput> page;   // operator.mode browser: the person's hand (main makes it)
    std::unique_ptr<Planner> stroke_planner;   // ... and the planner its strokes run on (main makes it)
    std::unique_ptr<Stroke> stroke;            // the stroke under way
    std::vector<StrokeDone> strokes_done;
    int page_scans = 0;
    HapticLoop device;
    Vec2 held_N;                 // the force the device renders over the block being integrated
    double held_z_N = 0;         // its z part (the stylus's z axis: operator.haptic.load_span_nN)
    double peak_force_z_N = 0;
    double reach_nm;                  // apex travel for the joystick's +-1
    double half_range_m;
    double peak_speed_m_per_s = 0;
    // the planner
    ObjectsView view;            // FW_STATE's objects, whole: view.whole() the latest set (highest seq, then fix id)
    ScanClient scan;
    ScanDewarp dewarp;           // the card's scanner model, followed from FW_STATE's drive: the planner's scans de-warped by it
    int scans = 0, fixes_sent = 0;
    bool plan_done = false;
    int64_t finished_seq = -1;       // the block whose force the planner finished on
    bool ending_seen = false;        // the simulator said the run ends
    std::chrono::steady_clock::time_point finished_sent;
    PlanPose hold_pose;

    Operator(const Scene &s, lcm::LCM &l, Heartbeat &h)
        : scene(s), lc(l), hb(h), script(s),
          device(s.op.haptic, s.op.hand, 1.0 / s.block_hz, to_stylus(s, s.start_nm())), reach_nm(s.op.kappa * s.field_nm / 2),
          half_range_m(s.op.haptic.half_range_mm * 1e-3), scan(l), dewarp(s)
    {
        scan.set_dewarp(&dewarp);
        if (s.op.haptic.load_span_nN > 0) device.place_z(press_for(s.load_at_nN(0)));   // the hand already pressing
    }

    static Vec2 to_stylus(const Scene &s, Vec2 p_nm)
    {
        const double reach = s.op.kappa * s.field_nm / 2, r = s.op.haptic.half_range_mm * 1e-3;
        return {(p_nm.x - s.field_center_nm.x) / reach * r, (p_nm.y - s.field_center_nm.y) / reach * r};
    }

    Reject on_force(const haptic_force_t &f)
    {
        if (f.seq == answered) {      // resent force: our pose was lost
            afm::publish(lc, AFM_CH_HAPTIC_POSE, last);
            return Reject::none;
        }
        if (f.seq < answered) return Reject::seq_past;
        if (f.seq > answered + 1) return Reject::seq_future;
        if (have_force) return Reject::none;   // the same force again, not yet answered
        force = f;
        have_force = true;
        return Reject::none;
    }

    // FW_STATE n comes with HAPTIC_FORCE n: one from further ahead than
    // the next force cannot have been sent yet (taking it would make every
    // later message look old). The planner reads its objects.
    Reject on_state(const fw_state_t &s)
    {
        const objects_t &m = s.objects;
        if (m.seq > answered + 2) return Reject::seq_future;
        dewarp.follow(s.seq, s.utime, s.piezo_nm[0], s.piezo_nm[1]);
        if (view.ready() && key_of(m) <= key_of(view.whole())) return Reject::seq_past;
        // held: before its base, taken when that comes
        return view.apply(m) == ObjectsView::Take::refused ? Reject::out_of_range : Reject::none;
    }

    Reject on_line(const scan_line_t &m)
    {
        scan.on_line(m);   // lines of another client's scan are not ours to count
        return Reject::none;
    }

    Reject on_heartbeat(const heartbeat_t &m)
    {
        if (run_over(m)) sim_done = true;
        if (says(m, "sim_afm", RunState::ending)) ending_seen = true;
        return Reject::none;
    }

    // The planner's "finished", again until the simulator says the run ends.
    void repeat_finished()
    {
        if (!plan_done || ending_seen || finished_seq < 0) return;
        if (std::chrono::steady_clock::now() - finished_sent < std::chrono::milliseconds(kFinishedRepeatMs)) return;
        hb.send(RunState::finished, finished_seq, block_end_utime(scene, finished_seq));
        finished_sent = std::chrono::steady_clock::now();
    }

    void publish_pose(Vec2 joy, bool engaged, double load_nN = 0, double joy_z = 0)
    {
        const int64_t n = force.seq;
        last.utime = block_end_utime(scene, n);
        last.seq = n + 1;
        last.joy[0] = std::clamp(joy.x, -1.0, 1.0);
        last.joy[1] = std::clamp(joy.y, -1.0, 1.0);
        last.joy[2] = std::clamp(joy_z, -1.0, 1.0);
        last.load_nN = load_nN > 0 ? load_nN : scene.load_at_nN(last.utime * 1e-6);
        last.engaged = engaged;
        answered = n;
        have_force = false;
        afm::publish(lc, AFM_CH_HAPTIC_POSE, last);
        hb.maybe_send(RunState::running, n, last.utime);
    }

    void count_force()
    {
        peak_force_N = std::max(peak_force_N, std::hypot(force.force_N[0], force.force_N[1]));
        peak_force_z_N = std::max(peak_force_z_N, std::fabs(force.force_N[2]));
        ++forces;
    }

    // The stylus's z axis: where the hand presses it for a load (nN): the
    // depth below the centre at which the stylus asks for that load.
    double press_for(double load_nN) const
    {
        return -std::clamp(load_nN / scene.op.haptic.load_span_nN, 0.0, 1.0) * half_range_m;
    }

    // operator.mode browser: the local scan the person asked for, at the
    // display's pitch and on its pixels, inside the field, asked at once
    // (realtime); the renderer pastes it into the display (kPageScanReqBase).
    // One at a time: a newer ask waits for the one under way.
    void page_scan()
    {
        if (scan.busy()) {
            scan.retry(kScanRetryMs);
            return;
        }
        HandInput::ScanAsk a;
        if (!page->take_scan(&a)) return;
        const int px = scene.out.image_px;
        const double pitch = scene.field_nm / px;
        const double x0 = scene.field_center_nm.x - scene.field_nm / 2, y0 = scene.field_center_nm.y - scene.field_nm / 2;
        const int n = std::clamp(static_cast<int>(std::lround(a.size_nm / pitch)), HandInput::kMinScanPx, px);
        const int c0 = std::clamp(static_cast<int>(std::lround((a.center_nm.x - x0) / pitch - n / 2.0)), 0, px - n);
        const int r0 = std::clamp(static_cast<int>(std::lround((a.center_nm.y - y0) / pitch - n / 2.0)), 0, px - n);
        const ScanRegion reg{x0 + c0 * pitch, y0 + r0 * pitch, n * pitch, n * pitch, n, n};
        scan.start(kPageScanReqBase + ++page_scans, reg, -1, false);   // the renderer places its lines by their own coordinates
    }

    // The hand on the device: block n integrated with the force of block
    // n - 1, the pose for n + 1 is where the stylus ends.
    void answer_by_hand()
    {
        count_force();
        if (page) {
            page->poll();
            page_scan();
            HandInput::PushAsk a;
            if (!scan.busy() && page->take_push(&a)) start_stroke(a);   // a page scan under way first
            if (stroke) {
                serve_stroke();
                return;
            }
        }
        const Vec2 aim_nm = page ? page->command().aim_nm : script.advance(1.0 / scene.block_hz, held_N);
        // The load the hand means: the page's, or the script's at the pose's time.
        const double want_nN = page ? page->command().load_nN : scene.load_at_nN(block_end_utime(scene, force.seq) * 1e-6);
        const bool has_z = scene.op.haptic.load_span_nN > 0;
        device.step(to_stylus(scene, aim_nm), held_N, has_z ? press_for(want_nN) : 0.0, held_z_N);
        held_N = {force.force_N[0], force.force_N[1]};
        held_z_N = force.force_N[2];
        const Vec2 x = device.position_m(), v = device.velocity_m_per_s();
        peak_speed_m_per_s = std::max(peak_speed_m_per_s, std::hypot(v.x, v.y));
        const Vec2 joy{x.x / half_range_m, x.y / half_range_m};
        const bool button = page ? page->command().engaged : true;
        if (has_z) {   // the stylus's depth sets the load; lifted to the centre, the tip leaves the surface
            const double load = device.load_nN();
            publish_pose(joy, button && load > 0, load > 0 ? load : scene.op.load_nN, device.z_m() / half_range_m);
        } else if (page) {
            publish_pose(joy, button, page->command().load_nN);
        } else {
            publish_pose(joy, true);
        }
    }

    // The joystick for an apex target in frame A: the card moves the
    // joystick's workspace with the drift it knows (fw_card), so the pose
    // is the target in the sample's coordinates.
    Vec2 joy_of(Vec2 tip_nm) const
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

    enum class Turn { pose, ended, run_over };
    // Serves the planner's requests for block n's force (its scans, its
    // fixes) until it hands over the pose for block n + 1 (published:
    // pose), finishes (ended) or the run ends (run_over). answer_block: the
    // pose of block n was the planner's, which waits for the model after it.
    Turn serve_planner(PlannerTurns &turns, bool answer_block)
    {
        const int64_t n = force.seq;
        if (answer_block) {
            if (!pump_until([&] { return view.ready() && view.whole().seq >= n; })) return Turn::run_over;
            turns.answer(view.whole(), block_end_utime(scene, n) * 1e-6);
        }
        while (true) {
            const PlannerTurns::Req r = turns.next(50);
            if (r == PlannerTurns::Req::None) {
                while (inbox->handle(0) > 0) {}   // all that came: the socket is the only queue
                if (sim_done) return Turn::run_over;
                continue;
            }
            if (r == PlannerTurns::Req::Block) {
                hold_pose = turns.pose();
                publish_pose(joy_of(hold_pose.tip_nm), hold_pose.engaged, hold_pose.load_nN);
                return Turn::pose;
            }
            if (r == PlannerTurns::Req::Scan) {
                const Field f = turns.field();
                ScanRegion reg{f.x0_nm, f.y0_nm, f.size_nm, f.size_nm, f.px, f.px};
                scan.start(kScanReqBase + ++scans, reg, n + 1);   // the sample as the simulator holds it after block n + 1
                if (!pump_until([&] { return !scan.busy(); }, &Operator::retry_scan)) return Turn::run_over;
                turns.answer(view.whole(), block_end_utime(scene, n) * 1e-6, &scan.heights());
                continue;
            }
            if (r == PlannerTurns::Req::Fix) {
                if (!send_fix(turns)) return Turn::run_over;
                continue;
            }
            return Turn::ended;   // Done or Failed
        }
    }

    // Serves the planner until it hands over the pose for block n + 1.
    void answer_by_planner(PlannerTurns &turns)
    {
        count_force();
        const int64_t n = force.seq;
        if (!plan_done) {
            if (serve_planner(turns, n >= 0) != Turn::ended) return;
            plan_done = true;
            finished_seq = n;
            hb.send(RunState::finished, n, block_end_utime(scene, n));   // the simulator ends the run soon after (before the pose)
            finished_sent = std::chrono::steady_clock::now();
        }
        publish_pose(joy_of(hold_pose.tip_nm), false);
    }

    // operator.mode browser, a stroke (operator.cpp): started from where
    // the hand holds the tip, lifted; served block by block (the stylus
    // carried along with the tip, the device rendering nothing meanwhile);
    // at its end the hand's target is where the planner left the tip,
    // lifted, and the page is told on the heartbeat ("push: ...").
    void start_stroke(const HandInput::PushAsk &a);
    void serve_stroke();
    void end_stroke();

    // A fix, until the card acknowledges it; the note says if it refused.
    bool send_fix(PlannerTurns &turns)
    {
        object_fix_t f{};
        f.utime = block_end_utime(scene, force.seq);
        f.fix_id = ++fixes_sent;
        f.object_id = turns.fix_object();
        f.scan_x_nm = turns.fix_at().x;
        f.scan_y_nm = turns.fix_at().y;
        f.kind = turns.fix_place() ? object_fix_t::KIND_PLACE : object_fix_t::KIND_DRIFT;
        const objects_t before = view.whole();
        auto sent = std::chrono::steady_clock::now();
        afm::publish(lc, AFM_CH_HOST_OBJECT_FIX, f);
        const bool ok = pump_until([&] {
            if (view.whole().fix_id >= f.fix_id) return true;
            if (std::chrono::steady_clock::now() - sent > std::chrono::milliseconds(kFixRetryMs)) {
                afm::publish(lc, AFM_CH_HOST_OBJECT_FIX, f);
                sent = std::chrono::steady_clock::now();
            }
            return false;
        });
        if (!ok) return false;
        const bool applied = fix_applied(before, view.whole(), f, kPm_nm);   // the card's answer is its model
        turns.answer(view.whole(), block_end_utime(scene, force.seq) * 1e-6, nullptr, applied ? "" : "refused: beyond the firmware's limit");
        return true;
    }
};


// operator_report.json: what the operator did (the hand's device and the
// contacts it felt, or the planner's account).
nlohmann::json operator_report(const Operator &op, const Planner *planner, const Scene &scene, const nlohmann::json &rejected);

}  // namespace afm
