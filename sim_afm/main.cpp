// sim_afm: the simulated AFM controller and sample on the bus.
//
// Owns the clock. Lockstep (default): publish analog block n, then wait for the
// firmware's AFM_CMD acknowledging n and, when the renderer falls behind or
// asks for a scan, for its frames (afm::frames_to_wait_for); resend block n
// on a timeout (udpm may drop). Real time: the same, paced by the wall clock.
#include <lcm/lcm-cpp.hpp>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "afm/analog_block_t.hpp"
#include "afm/heartbeat_t.hpp"
#include "afm/render_frame_t.hpp"
#include "afm/scan_line_t.hpp"
#include "afm/scan_req_t.hpp"
#include "afm/sim_truth_t.hpp"
#include "afm/tip_cmd_t.hpp"
#include "aside.hpp"
#include "bus.hpp"
#include "inbox.hpp"
#include "log_tail.hpp"
#include "objects_view.hpp"
#include "process.hpp"
#include "run_process.hpp"
#include "lockstep.hpp"
#include "scene.hpp"
#include "world.hpp"

namespace {

// sim_report.json's wire_solver: the flexible wires' Newton solver over the
// run (World::wire_solver); null when the scene has no flexible wire.
nlohmann::json wire_solver_report(const afm::sim::World::WireSolver &w)
{
    if (w.flexible == 0) return nullptr;
    return {{"flexible_wires", w.flexible},         {"pushes_solved", w.solved},
            {"unconverged", w.unconverged},          {"regularised", w.regularised},
            {"worst_iterations", w.worst_iterations}, {"max_iterations", w.max_iterations}};
}

// sim_report.json's solver: the contact solver over the run (World::solver,
// physics.md 5.1), the one owner of these field names; run.json's sim.solver
// and the verdict's solver check read them.
nlohmann::json solver_report(const afm::sim::World::SolverStats &s)
{
    return {{"samples", s.samples},
            {"sweeps", s.sweeps},
            {"max_sweeps_per_sample", s.max_sweeps},
            {"cap", s.cap},
            {"worst_force_residual_nN", s.worst_force_nN},
            {"worst_gap_nm", s.worst_gap_nm},
            {"force_tolerance_nN", afm::sim::kSolverForceTol_nN},
            {"gap_tolerance_nm", afm::sim::kSolverGapTol_nm},
            {"unconverged_samples", s.unconverged}};
}

}  // namespace

namespace {

constexpr int64_t kHeartbeatPeriodUs = 250000;   // the launcher's progress line reads these
// With --follow-log, the simulator stays at most this many analog blocks (about
// 8 messages each) and scan lines ahead of what the run's record holds
// (log_tail.hpp), so that a recorder starved of CPU slows the run instead of
// losing messages. The launcher passes its own window (log_window_blocks(),
// from its receive buffer); this is the default when run by hand.
constexpr int64_t kLogWindowBlocks = afm::kLogWindowMin;   // the default of --log-window
// Scan requests for the next block the simulator keeps at most (each client
// has one scan under way; more are refused as out_of_range).
constexpr std::size_t kLaterScans = 16;
constexpr int64_t kLogWindowLines = 16;

struct Sim {
    const afm::Scene &scene;
    lcm::LCM &lc;
    afm::sim::World world;
    afm::Lifecycle &life;

    std::set<std::string> ready;       // peers that said ready
    bool go = false;                   // launcher said running
    std::unique_ptr<afm::LogTail> log;  // --follow-log
    int64_t log_waits = 0;             // times the run waited for the logger
    double log_wait_s = 0;             // the wall time it waited for the logger
    int64_t frame_waits = 0;           // blocks whose card answer came before the renderer's frames
    double frame_wait_s = 0;           // the wall time those blocks waited for the frames after the answer
    double frame_wait_worst_s = 0;     // the longest of those waits, and its block
    int64_t frame_wait_worst_block = -1;
    bool abort = false;
    int64_t acked = -1;                // last acknowledged block
    int frames_done = 0;               // frames the renderer has written
    afm::tip_cmd_t pending_cmd{};
    bool have_cmd = false;
    int64_t scan_lines_sent = 0;
    // Wall time serving scans (serve_scan) before the first block and
    // during the blocks (the renderer's local scans, the final scan of the
    // display check): sim_report.json, start_scan_wall_seconds and
    // loop_scan_wall_seconds; ./afm bench bus takes the latter out of the
    // lockstep's cost per block.
    bool in_loop = false;
    double start_scan_s = 0, loop_scan_s = 0;
    int64_t finished_seq = -1;         // the operator's planner finished with the pose answering this block
    bool ending_announced = false;
    int64_t waiting_after = -1;        // the analog block the simulator has published and waits after (-1: none yet)
    std::vector<afm::scan_req_t> later_scans;   // asked for a later block (scan_req_t.at_seq)

    Sim(const afm::Scene &s, afm::Lifecycle &li) : scene(s), lc(li.bus()), world(s), life(li) {}

    // The scans this scene's own clients may ask for (the renderer's at the
    // display's pitch, within the field; the planner's at its local scans'
    // pitch, at most a few fields wide): a side at most 4 fields, a pitch at
    // least half the finest of theirs. A request beyond them would stall the
    // run and grow its log (tests/e2e/test_hostile.py forges one).
    double max_scan_side_nm() const { return 4.0 * scene.field_nm; }
    double min_scan_pitch_nm() const
    {
        double p = scene.field_nm / scene.out.image_px;
        // the planner's local scans: a planning run's, or the pushes a page or a program asks for
        if (scene.op.plan.enabled || scene.op.mode == "browser" || scene.op.mode == "env")
            p = std::min(p, scene.op.plan.scan_size_nm / scene.op.plan.scan_px);
        return 0.5 * p;
    }

    // Waits (briefly sleeping) until the log holds block `seq` (its analog
    // block, pose and command: the card's inputs and answer, so a complete
    // log replays) and `lines` scan lines.
    void wait_for_log(int64_t seq, int64_t lines)
    {
        if (!log) return;
        // the file is read only when what it held last time is not enough
        if (log->last_block_recorded() >= seq && log->scan_lines() >= lines) return;
        const auto t0 = std::chrono::steady_clock::now();
        for (;;) {
            log->poll(waiting_after);   // the last block published
            if (log->last_block_recorded() >= seq && log->scan_lines() >= lines) break;
            ++log_waits;
            std::this_thread::sleep_for(std::chrono::microseconds(50));
        }
        log_wait_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }

    afm::Reject on_heartbeat(const afm::heartbeat_t &m)
    {
        using afm::RunState;
        // "finished" ends the run early only where a planner runs, or a
        // program's steps (operator.mode env: docs/env.md) (a forged
        // one cut a scene without one to 27 % of its length)
        if (afm::says(m, "operator", RunState::finished)) {
            if (!scene.op.plan.enabled && scene.op.mode != "env") return afm::Reject::out_of_range;
            if (finished_seq < 0) finished_seq = m.seq;
        }
        if (m.state == afm::state_text(RunState::ready) || m.state == afm::state_text(RunState::running)) ready.insert(m.name);
        if (afm::says(m, "launcher", RunState::running)) go = true;
        if (afm::says(m, "launcher", RunState::stop)) abort = true;
        return afm::Reject::none;
    }

    // The card's answer to the block the simulator waits after; an older
    // one is a duplicate (the card answers a resend again).
    afm::Reject on_cmd(const afm::tip_cmd_t &m)
    {
        if (m.ack_seq <= acked) return afm::Reject::seq_past;
        if (m.ack_seq > waiting_after) return afm::Reject::seq_future;
        acked = m.ack_seq;
        pending_cmd = m;
        have_cmd = true;
        return afm::Reject::none;
    }

    // A frame the renderer cannot have drawn yet (it draws a frame once the
    // simulator has published the blocks before it) is refused.
    afm::Reject on_frame(const afm::render_frame_t &m)
    {
        if (m.index < 0) return afm::Reject::out_of_range;
        if (m.index + 1 > afm::frames_due(scene, afm::block_end_utime(scene, std::max<int64_t>(waiting_after, 0))))
            return afm::Reject::seq_future;
        frames_done = std::max(frames_done, m.index + 1);
        return afm::Reject::none;
    }

    afm::Reject on_scan_req(const afm::scan_req_t &m)
    {
        if (m.nx < 1 || m.ny < 1 || m.nx > 8192 || m.ny > 8192 || m.first_line < 0 || m.n_lines < 0 || !(m.width_nm > 0) ||
            !(m.height_nm > 0))
            return afm::Reject::out_of_range;   // counted, not said (a flood would fill the log)
        if (m.width_nm > max_scan_side_nm() || m.height_nm > max_scan_side_nm() || m.width_nm / m.nx < min_scan_pitch_nm() ||
            m.height_nm / m.ny < min_scan_pitch_nm())
            return afm::Reject::out_of_range;   // beyond what the scene's clients ask (counted, not said)
        // One for a later block waits until the simulator waits after it; a
        // client asks for the block its next pose answers, so more than one
        // block ahead (or more than kLaterScans waiting) is refused.
        if (m.at_seq > waiting_after) {
            if (m.at_seq > waiting_after + 1) return afm::Reject::seq_future;
            if (later_scans.size() >= kLaterScans) return afm::Reject::out_of_range;
            later_scans.push_back(m);
            return afm::Reject::none;
        }
        serve_scan(&m);
        return afm::Reject::none;
    }

    // The planner has finished: the run ends one frame period after it (a
    // rule of the block it finished in, so a run ends at the same block
    // every time; a frame period after the present block if the news came
    // late, so the renderer still has a frame to end on), and says so.
    void end_early(int64_t n, int64_t *blocks, int64_t *ended_at)
    {
        if (finished_seq < 0 || ending_announced) return;
        ending_announced = true;
        const int64_t frame = static_cast<int64_t>(std::ceil(scene.block_hz / scene.frame_rate_hz));
        const int64_t end = std::max(n + frame, finished_seq + 1 + frame);
        if (end + 1 < *blocks) {
            *blocks = end + 1;
            *ended_at = end;
        }
        for (int i = 0; i < 3; ++i)
            life.heartbeat().send(afm::RunState::ending, *blocks - 1, afm::block_end_utime(scene, *blocks - 1), "the planner finished");
    }

    // The scans asked for the block the simulator now waits after.
    void serve_due_scans()
    {
        for (std::size_t i = 0; i < later_scans.size();) {
            if (later_scans[i].at_seq <= waiting_after) {
                const afm::scan_req_t r = later_scans[i];
                later_scans.erase(later_scans.begin() + static_cast<long>(i));
                serve_scan(&r);
            } else {
                ++i;
            }
        }
    }

    // While a scan is served (it may take seconds), a heartbeat every
    // kScanBeat says so in its detail ("scan K / N lines"), in the state the
    // simulator is in: the launcher's progress line names the stage.
    static constexpr auto kScanBeat = std::chrono::milliseconds(500);
    void say_scanning(const afm::scan_req_t *m, int line, std::chrono::steady_clock::time_point *said)
    {
        const auto now = std::chrono::steady_clock::now();
        if (now - *said < kScanBeat) return;
        *said = now;
        const int64_t seq = std::max<int64_t>(waiting_after, -1);
        life.heartbeat().send(in_loop ? afm::RunState::running : afm::RunState::ready, seq,
                              seq >= 0 ? afm::block_end_utime(scene, seq) : 0,
                              "scan " + std::to_string(line - m->first_line) + " / " + std::to_string(m->n_lines) + " lines");
    }

    void serve_scan(const afm::scan_req_t *m)
    {
        const auto t0 = std::chrono::steady_clock::now();
        auto said = t0;
        const int last = std::min(m->ny, m->first_line + m->n_lines);
        const double dx = m->width_nm / m->nx, dy = m->height_nm / m->ny;
        std::vector<afm::sim::ScanPoint> points;
        for (int j = m->first_line; j < last; ++j) {
            afm::scan_line_t line;
            line.utime = acked >= 0 ? afm::block_end_utime(scene, acked) : 0;
            line.req_id = m->req_id;
            line.line = j;
            line.n_lines = m->ny;
            line.x0_nm = m->x0_nm + 0.5 * dx;
            line.y_nm = m->y0_nm + (j + 0.5) * dy;
            line.dx_nm = dx;
            line.n = m->nx;
            line.height_nm.resize(m->nx);
            line.defl_v.resize(m->nx);
            line.lat_v.resize(m->nx);
            points.resize(m->nx);
            world.scan_line(line.x0_nm, dx, m->nx, line.y_nm, m->y0_nm + 0.5 * dy, points.data(), dy);
            for (int i = 0; i < m->nx; ++i) {
                const afm::sim::ScanPoint &p = points[static_cast<std::size_t>(i)];
                line.height_nm[i] = p.height_nm;
                line.defl_v[i] = p.sn_v;
                line.lat_v[i] = p.sl_v;
            }
            wait_for_log(-1, scan_lines_sent - kLogWindowLines);
            afm::publish(lc, AFM_CH_AFM_SCAN_LINE, line);
            ++scan_lines_sent;
            say_scanning(m, j + 1, &said);
        }
        (in_loop ? loop_scan_s : start_scan_s) += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
};

afm::objects_t truth_objects(const afm::Scene &s, const afm::sim::World &w, int64_t seq)
{
    afm::objects_t o{};
    o.utime = afm::block_end_utime(s, seq);
    o.seq = seq;
    for (std::size_t i = 0; i < w.particles().size(); ++i) {
        const auto &p = w.particles()[i];
        const Eigen::Vector2d c = w.particle_position(i);
        afm::particle_t q;
        q.id = p.id;
        q.x_nm = c.x();
        q.y_nm = c.y();
        q.radius_nm = p.r;
        q.in_contact = p.in_contact;
        o.particles.push_back(q);
    }
    o.n_particles = static_cast<int32_t>(o.particles.size());
    for (const auto &wire : w.wires()) {
        afm::wire_t q;
        q.id = wire->id;
        q.diameter_nm = wire->d_nm;
        for (const auto &x : wire->nodes()) {
            const Eigen::Vector2d a = w.to_frame_A(x);
            q.x_nm.push_back(a.x());
            q.y_nm.push_back(a.y());
        }
        q.n = static_cast<int32_t>(q.x_nm.size());
        q.in_contact = wire->in_contact;
        q.axis_z_nm = w.wire_axis_height_nm(o.wires.size());
        o.wires.push_back(q);
    }
    o.n_wires = static_cast<int32_t>(o.wires.size());
    for (const auto &t : w.trenches()) {
        afm::trench_t q;
        q.id = t.id;
        for (std::size_t i = 0; i < t.p.size(); ++i) {
            const Eigen::Vector2d a = w.to_frame_A(t.p[i]);
            q.x_nm.push_back(a.x());
            q.y_nm.push_back(a.y());
        }
        q.depth_nm = t.depth_nm;
        q.width_nm = t.width_nm;
        q.n = static_cast<int32_t>(q.x_nm.size());
        o.trenches.push_back(q);
    }
    o.n_trenches = static_cast<int32_t>(o.trenches.size());
    o.drift_nm[0] = w.drift().x();
    o.drift_nm[1] = w.drift().y();
    return o;
}

// The command line of sim_afm (kProcess below: each option's one check).
struct Options {
    std::string scene_path, out_dir, follow_log;
    int64_t log_window = kLogWindowBlocks;
    bool renderer = true;
    double drop_p = 0;
    int resend_ms = 100;
    std::vector<int> aside_cpus;
};

constexpr const char *kOptions = "options:";
constexpr long long kMany = std::numeric_limits<long long>::max();

const afm::Process<Options> kProcess = {
    {"sim_afm",
    "usage: sim_afm --scene FILE --out DIR [options]\n"
    "  The simulated AFM of a run; normally started by ./afm run inside the run's\n"
    "  network namespace.\n",
    {
        {{"--scene", "FILE", nullptr, nullptr, true}, afm::cli::text(&Options::scene_path)},
        {{"--out", "DIR", nullptr, nullptr, true}, afm::cli::text(&Options::out_dir)},
        {{"--inject-drop", "P", kOptions,
          "drop the first transmission of each analog block with\n"
          "probability P (failure injection: tests the resend path)"},
         afm::cli::number(&Options::drop_p, afm::cli::in_range(0, 1, true), "a probability")},
        {{"--resend-ms", "MS", kOptions, "send an analog block again when MS wall ms pass without\nits answer (default 100)"},
         afm::cli::whole(&Options::resend_ms, 1, kMany, "a number of ms")},
        {{"--follow-log", "LOG", kOptions, "stay within a few blocks of what the run's record has\nwritten to LOG"},
         afm::cli::text(&Options::follow_log)},
        {{"--log-window", "BLOCKS", kOptions,
          "with --follow-log, how many blocks ahead of the log the simulator may\n"
          "run (default 8; the launcher passes log_window_blocks() of its record's\n"
          "receive buffer, bus/log_tail.hpp; ./afm bench bus varies it)"},
         afm::cli::whole(&Options::log_window, 1, kMany, "a number of blocks")},
        {{"--aside-cpus", "LIST", kOptions,
          "the CPUs (\"0-1\") the thread that publishes SIM_TRUTH aside may use\n"
          "(bus/aside.hpp; the launcher passes every CPU of the run)"},
         afm::cli::cpus(&Options::aside_cpus)},
        {{"--no-renderer", nullptr, kOptions,
          "no renderer on the bus; the simulator waits for no frames (./afm bench\n"
          "bus measures the lockstep without it). With one, the simulator runs at\n"
          "most 2 frames ahead of it, and waits for it at each frame where it asks\n"
          "for a scan."},
         afm::cli::flag(&Options::renderer, false)},
    }},
    {AFM_CH_AFM_HEARTBEAT, AFM_CH_AFM_CMD, AFM_CH_RENDER_FRAME, AFM_CH_AFM_SCAN_REQ},
    {AFM_CH_AFM_ANALOG, AFM_CH_AFM_SCAN_LINE, AFM_CH_SIM_TRUTH},
    [](const Options &o) { return o.out_dir + "/sim_report.json"; }};

// The lockstep loop of a run: one analog block after another, each answered
// by the card (and by the renderer's frames when due) before the next.
struct Loop {
    Sim &sim;
    lcm::LCM &lc;
    afm::Inbox &inbox;
    afm::Aside &aside;
    const afm::Scene &scene;
    const Options &opt;
    const int spb;
    int64_t blocks;
    int64_t ended_early_at = -1;   // the last block, when the planner finished first
    int64_t resends = 0, dropped = 0;
    double wall_s = 0;
    std::mt19937_64 drop_rng;
    std::bernoulli_distribution drop;
    afm::analog_block_t blk;
    std::size_t next_change = 0;   // operator.cantilever_changes applied so far
    afm::ObjectsDiff truth_diff;   // SIM_TRUTH lists the objects that changed (objects_t.complete)

    Loop(Sim &s, lcm::LCM &l, afm::Inbox &in, afm::Aside &as, const Options &o)
        : sim(s), lc(l), inbox(in), aside(as), scene(s.scene), opt(o), spb(s.scene.samples_per_block()),
          blocks(s.scene.total_blocks()), drop_rng(s.scene.seed ^ 0x5eedULL), drop(o.drop_p)
    {
        blk.fs_hz = scene.sample_rate_hz;
        blk.n = spb;
        blk.sn_v.resize(spb);
        blk.sl_v.resize(spb);
        blk.piezo_x_nm.resize(spb);
        blk.piezo_y_nm.resize(spb);
        blk.piezo_z_nm.resize(spb);
    }

    // A cantilever change: the work space jumps against the scanner.
    void apply_cantilever_changes(int64_t n)
    {
        while (next_change < scene.op.cantilever_changes.size() &&
               std::llround(scene.op.cantilever_changes[next_change].at_s * 1e6) <= std::llround(n * 1e6 / scene.block_hz)) {
            const afm::Vec2 o = scene.op.cantilever_changes[next_change++].offset_nm;
            sim.world.add_drift(Eigen::Vector2d(o.x, o.y));
        }
    }

    // Block n's samples into blk; the block's truth aside (SIM_TRUTH).
    void simulate_block(int64_t n)
    {
        blk.seq = n;
        blk.utime = std::llround(n * 1e6 / scene.block_hz);
        Eigen::Vector3d force_sum = Eigen::Vector3d::Zero();   // the block's mean true force, as FW_STATE's
        for (int i = 0; i < spb; ++i) {
            const afm::sim::Sample s = sim.world.step();
            force_sum += sim.world.tip_force();
            blk.sn_v[i] = s.sn_v;
            blk.sl_v[i] = s.sl_v;
            blk.piezo_x_nm[i] = s.piezo_nm.x();
            blk.piezo_y_nm[i] = s.piezo_nm.y();
            blk.piezo_z_nm[i] = s.piezo_nm.z();
        }
        afm::sim_truth_t truth;
        truth.utime = afm::block_end_utime(scene, n);
        truth.seq = n;
        for (int k = 0; k < 2; ++k) {
            truth.tip_nm[k] = sim.world.apex()[k];
            truth.piezo_nm[k] = sim.world.piezo()[k];
        }
        truth.tip_nm[2] = truth.piezo_nm[2] = sim.world.piezo_z();
        for (int k = 0; k < 3; ++k) truth.force_nN[k] = force_sum[k] / spb;
        truth.objects = truth_diff.next(truth_objects(scene, sim.world, n));
        aside.post(AFM_CH_SIM_TRUTH, truth);
    }

    // Waits for the card's answer to block n (and the frames due), resending
    // the block every resend_ms; false if the launcher stopped the run.
    bool wait_for_answer(int64_t n)
    {
        const int frames_needed = opt.renderer ? afm::frames_to_wait_for(scene, n, blocks) : 0;
        auto last_send = std::chrono::steady_clock::now();
        sim.waiting_after = n;
        sim.serve_due_scans();
        std::chrono::steady_clock::time_point answered{};   // the card answered, the frames had not come
        while (sim.acked < n || sim.frames_done < frames_needed) {
            inbox.handle(opt.resend_ms);
            if (sim.acked >= n && sim.frames_done < frames_needed && answered == std::chrono::steady_clock::time_point{})
                answered = std::chrono::steady_clock::now();
            sim.serve_due_scans();
            if (sim.abort) return false;
            if (std::chrono::steady_clock::now() - last_send >= std::chrono::milliseconds(opt.resend_ms)) {
                afm::publish(lc, AFM_CH_AFM_ANALOG, blk);
                ++resends;
                last_send = std::chrono::steady_clock::now();
            }
            sim.life.running(n, blk.utime, kHeartbeatPeriodUs);
        }
        if (answered != std::chrono::steady_clock::time_point{}) {
            const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - answered).count();
            ++sim.frame_waits;
            sim.frame_wait_s += waited;
            if (waited > sim.frame_wait_worst_s) {
                sim.frame_wait_worst_s = waited;
                sim.frame_wait_worst_block = n;
            }
        }
        return true;
    }

    // The whole run; false if the launcher stopped it.
    bool run()
    {
        const auto wall0 = std::chrono::steady_clock::now();
        sim.in_loop = true;
        {
            const afm::Vec2 s0 = scene.start_nm();
            sim.world.command(Eigen::Vector2d(s0.x, s0.y), scene.op.load_nN, scene.start_engaged());
        }
        for (int64_t n = 0; n < blocks; ++n) {
            sim.wait_for_log(n - opt.log_window, 0);
            apply_cantilever_changes(n);
            simulate_block(n);
            if (drop(drop_rng)) ++dropped;
            else afm::publish(lc, AFM_CH_AFM_ANALOG, blk);
            if (scene.time_mode == "realtime")
                std::this_thread::sleep_until(wall0 + std::chrono::microseconds(afm::block_end_utime(scene, n)));
            if (!wait_for_answer(n)) return false;
            if (sim.have_cmd) {
                sim.world.command(Eigen::Vector2d(sim.pending_cmd.piezo_x_nm, sim.pending_cmd.piezo_y_nm),
                                  sim.pending_cmd.load_nN, sim.pending_cmd.engaged);
                sim.have_cmd = false;
            }
            sim.end_early(n, &blocks, &ended_early_at);
            sim.life.running(n, afm::block_end_utime(scene, n), kHeartbeatPeriodUs);
        }
        wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
        return true;
    }

    // sim_report.json: the effects built and the time each took; lockstep statistics.
    nlohmann::json report() const
    {
        nlohmann::json effects = nlohmann::json::array();
        for (const auto &c : sim.world.clocks()) effects.push_back({{"name", c.name}, {"seconds", c.seconds}});
        return {{"effects", effects},
                {"effects_listed", scene.effects},
                {"models_built", sim.world.models_built()},
                {"blocks", blocks},
                {"ended_early_at_block", ended_early_at},
                {"samples", blocks * spb},
                {"resends", resends},
                {"log_window_waits", sim.log_waits},
                {"log_window_wait_seconds", sim.log_wait_s},
                {"frame_window_waits", sim.frame_waits},
                {"frame_window_wait_seconds", sim.frame_wait_s},
                {"frame_window_worst_wait_seconds", sim.frame_wait_worst_s},
                {"frame_window_worst_wait_block", sim.frame_wait_worst_block},
                {"injected_drops", dropped},
                {"loop_wall_seconds", wall_s},
                {"loop_scan_wall_seconds", sim.loop_scan_s},
                {"start_scan_wall_seconds", sim.start_scan_s},
                {"scan_lines_sent", sim.scan_lines_sent},
                {"piezo_clamped_samples", sim.world.piezo_clamped_samples()},
                {"scan_points_clamped", sim.world.scan_points_clamped()},
                {"wire_ridden_samples", sim.world.ridden_samples()},
                {"wire_friction_nN_per_um", scene.wire_friction_nN_per_um()},
                {"wire_contact_width_nm", scene.wire_contact_width_nm()},
                {"wire_axis_heights_nm", sim.world.wire_axis_heights_nm()},
                {"wire_solver", wire_solver_report(sim.world.wire_solver())},
                {"solver", solver_report(sim.world.solver())},
                {"aside", aside.report()},
                {"rejected", inbox.report()}};
    }
};

}  // namespace

int main(int argc, char **argv)
{
    return afm::run_process(kProcess, argc, argv, [](const Options &opt, afm::Lifecycle &life) {
        const afm::Scene scene = afm::load_scene(opt.scene_path);
        lcm::LCM &lc = life.bus();
        Sim sim(scene, life);
        afm::Aside aside(opt.aside_cpus);   // SIM_TRUTH: the record's, no process of the lockstep reads it
        if (!opt.follow_log.empty()) sim.log = std::make_unique<afm::LogTail>(opt.follow_log);
        afm::Inbox inbox(&lc);
        inbox.on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [&](const afm::heartbeat_t &m) { return sim.on_heartbeat(m); });
        inbox.on<afm::tip_cmd_t>(AFM_CH_AFM_CMD, [&](const afm::tip_cmd_t &m) { return sim.on_cmd(m); });
        inbox.on<afm::render_frame_t>(AFM_CH_RENDER_FRAME, [&](const afm::render_frame_t &m) { return sim.on_frame(m); });
        inbox.on<afm::scan_req_t>(AFM_CH_AFM_SCAN_REQ, [&](const afm::scan_req_t &m) { return sim.on_scan_req(m); });
        afm::check_lockstep_reads(scene, inbox.channels(), "sim_afm");
        life.check_subscriptions(inbox.channels());

        // Start: serve scans until every peer is ready and the launcher says go.
        std::set<std::string> peers = {"fw_node", "operator"};
        if (opt.renderer) peers.insert("renderer");
        life.serve([] { return afm::Progress{}; }, [&](int ms) { inbox.handle(ms); },
                   [&] { return sim.abort || (sim.go && std::includes(sim.ready.begin(), sim.ready.end(), peers.begin(), peers.end())); });
        if (sim.abort) return static_cast<int>(afm::kExitRunOverEarly);
        Loop loop(sim, lc, inbox, aside, opt);
        const auto report = life.report_from([&] { return loop.report(); });   // sim_report.json
        if (!loop.run()) return static_cast<int>(afm::kExitRunOverEarly);
        // at once: the launcher reads each process's CPU at the loop's end (run.json timing)
        life.heartbeat().send(afm::RunState::running, loop.blocks - 1, afm::block_end_utime(scene, loop.blocks - 1), "loop over");
        aside.flush();   // the record holds every block before "done", and the report counts them all
        life.done(loop.blocks - 1, afm::block_end_utime(scene, loop.blocks - 1), 3, [&] { inbox.handle(20); });
        return static_cast<int>(afm::kExitOk);
    });
}
