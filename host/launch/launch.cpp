#include "launch.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <thread>

#include <nlohmann/json.hpp>

#include "afm/heartbeat_t.hpp"
#include "bus.hpp"
#include "bus_key.hpp"
#include "card_setup.hpp"
#include "haptic_bound.hpp"
#include "log_tail.hpp"
#include "summary.hpp"
#include "warnings.hpp"

namespace afm::launch {

namespace fs = std::filesystem;

namespace {

// After a datagram wakes the launcher, it sleeps this long before it records
// the next ones, so that it records a block's datagrams in one wake-up, not
// eight (the simulator's log window, log_window_blocks(), is 8 to 64 blocks;
// ./afm bench bus measures it).
constexpr int kBatchUs = 500;

// Once every process has exited, what they sent is in the tap's socket or a
// softirq away from it (loopback delivers in the sender's system call, or
// on ksoftirqd soon after): the record takes the bus until it has been
// quiet for kQuietMs, at most kDrainMs, and is closed: a short run does not
// wait the whole kDrainMs.
constexpr int kQuietMs = 20;
constexpr int kDrainMs = 150;
constexpr double kSpyWaitS = 10.0;   // --spy: the longest the run waits for lcm-spy to listen

// Whether the planner can serve the scene's targets (pattern.hpp), asked of
// the operator, which owns the planner: `operator --check-targets` prints
// the refusal itself. The launcher does not link OpenCV (the text and PNG
// patterns need it) so that it starts in a few ms, not 60: it is on the path
// of every run. Returns -1 if they can be served, with *plan the plan's
// simulated time as the operator estimated it (plan_estimate.hpp: the one
// line it prints on stdout), else 2 (said on stderr).
int check_targets(const std::string &scene_path, afm::PlanEstimate *plan)
{
    const std::string op = exe_dir() + "/operator";
    std::vector<char *> a = {const_cast<char *>(op.c_str()), const_cast<char *>("--scene"), const_cast<char *>(scene_path.c_str()),
                             const_cast<char *>("--check-targets"), nullptr};
    int out[2];
    if (pipe2(out, O_CLOEXEC) != 0) {
        std::fprintf(stderr, "afm_launch: cannot check the planner's targets: pipe: %s\n", std::strerror(errno));
        return 2;
    }
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_adddup2(&fa, out[1], STDOUT_FILENO);
    pid_t pid = -1;
    const int e = posix_spawn(&pid, op.c_str(), &fa, nullptr, a.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    close(out[1]);
    std::string line;
    for (char b[4096]; e == 0;) {
        const ssize_t n = read(out[0], b, sizeof b);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        line.append(b, static_cast<std::size_t>(n));
    }
    close(out[0]);
    if (e != 0) {
        std::fprintf(stderr, "afm_launch: cannot check the planner's targets: cannot execute %s: %s\n", op.c_str(), std::strerror(e));
        return 2;
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) {
        try {
            *plan = afm::plan_estimate_from_json(nlohmann::json::parse(line));
            return -1;
        } catch (const nlohmann::json::exception &x) {
            std::fprintf(stderr, "afm_launch: %s --check-targets: cannot read the plan's estimate '%s': %s\n", op.c_str(),
                         line.substr(0, 200).c_str(), x.what());
            return 2;
        }
    }
    if (!(WIFEXITED(status) && WEXITSTATUS(status) == 2))
        std::fprintf(stderr, "afm_launch: cannot check the planner's targets: %s --check-targets %s\n", op.c_str(),
                     WIFEXITED(status) ? ("exited " + std::to_string(WEXITSTATUS(status))).c_str()
                                       : ("died of signal " + std::to_string(WTERMSIG(status))).c_str());
    return 2;
}

// The force loop outside its stability bound with no passivity check: said, not refused.
void warn_haptic_bound(const afm::Scene &s, const afm::CardSetup &card, const std::string &path)
{
    const afm::HapticBound b = afm::haptic_bound(s, card.config());
    if (!b.passive || !b.within_device)
        std::fprintf(stderr, "%s: warning: the force loop is outside its stability bound (K_r %.0f N/m, K_max %.0f N/m, the device's "
                     "limit %.0f N/m) and operator.haptic.passivity_check is false: the device's passivity controller will clamp it\n",
                     path.c_str(), b.rendered_N_per_m, b.max_rendered_N_per_m, s.op.haptic.max_stiffness_N_per_m);
}

// --estimate: the estimate and the work it counts, one JSON line on stdout;
// a planning run's also "plan": the planner's simulated time (plan_estimate.hpp).
void print_estimate(const afm::WallEstimate &e, const afm::PlanEstimate *plan)
{
    nlohmann::json j = {{"blocks", e.blocks},       {"samples", e.samples},   {"scan_px", e.scan_px},
                        {"rough_scan_px", e.rough_scan_px}, {"frame_px", e.frame_px}, {"wire_samples", e.wire_samples},
                        {"seconds", e.seconds},     {"planned", e.planned},   {"realtime", e.realtime}};
    if (plan) j["plan"] = afm::plan_estimate_json(*plan);
    std::printf("%s\n", j.dump().c_str());
}

// --check: the estimate in a line (a long one is a warning already).
void say_estimate(const std::string &path, const afm::Scene &s)
{
    const afm::WallEstimate e = afm::estimate_wall(s);
    if (e.realtime)
        std::printf("%s: a realtime run: it takes duration_s, %.4g s, of wall time\n", path.c_str(), s.duration_s);
    else
        std::printf("%s: the run's wall time, estimated from its size: about %.*f s%s\n", path.c_str(), e.seconds < 10 ? 1 : 0, e.seconds,
                    e.planned ? " if it runs to duration_s (a planned run ends when the planner is done)" : "");
}

}  // namespace

// --view-fd: kept from every process but afm_view_bridge (spawn hands it
// to that one) and closed here once the bridge has it
Launch::Launch(Options o) : o_(std::move(o)), folder_(o_.out_dir)
{
    if (o_.view_fd >= 0) fcntl(o_.view_fd, F_SETFD, FD_CLOEXEC);
}

Launch::~Launch()
{
    if (o_.view_fd >= 0) close(o_.view_fd);
}

int Launch::check_scene()
{
    try {
        scene_ = afm::load_scene(o_.scene_path);
    } catch (const afm::SceneError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
    }
    if (const std::string why_fw = afm::card_refusal(scene_); !why_fw.empty()) {
        std::fprintf(stderr, "%s: %s\n", o_.scene_path.c_str(), why_fw.c_str());
        return 2;
    }
    // The force loop's stability bound (haptic_bound.hpp) and the planner's targets.
    const afm::CardSetup card(scene_);
    if (const std::string why = afm::haptic_refusal(scene_, card.config()); !why.empty()) {
        std::fprintf(stderr, "%s: %s\n", o_.scene_path.c_str(), why.c_str());
        return 2;
    }
    if (!scene_.op.plan.enabled && !scene_.op.haptic.passivity_check && !(o_.check_only && o_.quiet))
        warn_haptic_bound(scene_, card, o_.scene_path);
    afm::PlanEstimate plan;
    if (scene_.op.plan.enabled) {
        if (const int code = check_targets(o_.scene_path, &plan); code >= 0) return code;
    }
    const afm::PlanEstimate *planned = scene_.op.plan.enabled ? &plan : nullptr;
    const auto warnings = afm::scene_warnings(scene_, card.config(), planned);
    if (!(o_.check_only && o_.quiet) || o_.strict)
        for (const auto &w : warnings) std::fprintf(stderr, "%s: %s%s\n", o_.scene_path.c_str(), o_.strict ? "" : "warning: ", w.c_str());
    if (o_.strict && !warnings.empty()) return 2;
    if (o_.estimate) print_estimate(afm::estimate_wall(scene_), planned);
    else if (o_.check_only && !o_.quiet && !o_.resolved) say_estimate(o_.scene_path, scene_);
    return -1;
}

// The run folder: a fresh one, or an earlier run's (its outputs replaced),
// with a copy of the scene that the run's processes read (what the run ran
// stays known: replay reads it, while the original may change).
int Launch::take_folder()
{
    try {
        if (const int code = folder_.take(); code >= 0) return code;
        out_ = fs::canonical(o_.out_dir).string();
        scene_abs_ = fs::canonical(o_.scene_path).string();
        scene_run_ = out_ + "/scene.yaml";
        const std::string text = afm::resolved_scene_text(scene_abs_);   // includes merged: it stands alone
        std::ofstream(scene_run_) << text;
        scene_hash_ = afm::scene_hash(text);
    } catch (const fs::filesystem_error &e) {
        std::fprintf(stderr, "afm_launch: cannot prepare output folder %s: %s\n", o_.out_dir.c_str(), e.what());
        return 2;
    }
    return -1;
}

int Launch::prepare()
{
    std::string why;
    if (!afm::multicast_stays_in_run(&why)) {
        std::fprintf(stderr, "afm_launch: %s\n", why.c_str());
        return 2;
    }
    if (const std::string e = hosts_.from_env(o_.hosts); !e.empty()) {
        std::fprintf(stderr, "afm_launch: %s\n", e.c_str());
        return 2;
    }
    if (const int code = take_folder(); code >= 0) return code;
    catch_stop_signals();
    try {
        setenv("LCM_DEFAULT_URL", bus_url(), 1);
        lc_ = afm::open_bus();
    } catch (const std::exception &e) {
        std::fprintf(stderr, "afm_launch: %s\n", e.what());
        return 2;
    }
    prog_.names = {"launcher"};
    for (const auto &name : run_process_names(o_)) prog_.names.insert(name);
    if (const int code = open_tap(); code >= 0) return code;
    inbox_ = std::make_unique<afm::Inbox>(nullptr);   // fed by the tap (pump())
    inbox_->on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [this](const afm::heartbeat_t &m) { return prog_.on_hb(m); });
    life_ = std::make_unique<afm::Lifecycle>("launcher", *lc_);
    wall0_ = std::chrono::steady_clock::now();
    return -1;
}

// The run's bus key (bus_key.hpp: AFM_BUS_MAC=off, none), before the
// tap that proves with it and the processes that inherit it; then the
// tap, admitting the run's own senders.
int Launch::open_tap()
{
    try {
        if (!afm::bus_mac_off()) {
            afm::set_run_key(afm::BusKey::make());
            key_fd_ = afm::run_key()->memfd();
        }
        tap_ = std::make_unique<afm::BusTap>(afm::bus_url());
        // The record and the launcher's heartbeats take only what the
        // run's own processes send on their channels (senders.hpp):
        // anything else is foreign, counted in run.json, never logged.
        senders_ = std::make_unique<afm::Senders>(afm::Senders::Scope::children);
        afm::Senders *s = senders_.get();
        tap_->admit_only([s](const std::string &channel, uint16_t port) { return s->admit(channel, port); });
        tap_->vet_with([s](const std::string &ch, const unsigned char *d, std::size_t n, uint16_t port) { return s->vet(ch, d, n, port); });
    } catch (const std::exception &e) {
        std::fprintf(stderr, "afm_launch: %s\n", e.what());
        return 2;
    }
    return -1;
}

int Launch::start()
{
    if (g_signal) {   // a signal before the run started: nothing ran
        std::fprintf(stderr, "afm_launch: interrupted before the run started\n");
        return 128 + g_signal;
    }
    try {
        recorder_ = std::make_unique<afm::BusRecorder>(out_ + "/bus.lcmlog");
        life_->starting(std::string("recording the bus; ") + afm::kScenePrefix + scene_hash_, 0);
        pump(0);
        recorder_->settle(true);
    } catch (const afm::LogError &e) {
        std::fprintf(stderr, "afm_launch: %s\n", e.what());
        return 1;
    }
    log_window_ = o_.log_window >= 0 ? o_.log_window : afm::log_window_blocks(tap_->receive_buffer_bytes());
    place();
    RunPlaces places{exe_dir(), out_, scene_run_, bus_url(), log_window_, &hosts_, &placement_, "", AFM_LCM_BIN, AFM_TYPES_JAR, AFM_SPY_LAUNCHER};
    if (hosts_.count == 2) places.parent_ports = afm::Senders::own_ports();
    for (const auto &p : run_processes(o_, places)) {
        const int sockets_before = p.name == "lcm-spy" ? udp_sockets_on_port(afm::kBusPort) : 0;
        sup_.start(p, key_fd_, o_.view_fd);
        if (p.name == "lcm-spy") wait_for_spy(sockets_before);
        if (p.view_fd) {   // the bridge has the page's pipe now
            close(o_.view_fd);
            o_.view_fd = -1;
        }
    }
    return -1;
}

// lcm-spy, before the run's processes: an LCM subscription sends nothing,
// so the run holds its start until lcm-spy's socket is bound on the bus's
// port in this namespace (a new one in /proc/net/udp*), or kSpyWaitS at
// most; a lockstep run would otherwise end before it listens.
// sockets_before: those on the port before it started.
void Launch::wait_for_spy(int sockets_before)
{
    Child *spy = sup_.observer("lcm-spy");
    const auto t0 = std::chrono::steady_clock::now();
    while (udp_sockets_on_port(afm::kBusPort) <= sockets_before && !g_signal) {
        spy->reap();
        const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        if (spy->exited || waited >= kSpyWaitS) {
            std::fprintf(stderr, "afm_launch: lcm-spy %s; the run starts without it listening (logs/lcm-spy.log)\n",
                         spy->exited ? "ended" : "did not bind the bus's port within 10 s");
            return;
        }
        pump(20);   // the record goes on meanwhile
    }
    if (!o_.quiet) std::fprintf(stderr, "afm_launch: lcm-spy listens on the bus; the run starts\n");
}

// The lockstep's CPU and the observers' (common/placement.hpp); the
// launcher is an observer. Nothing pinned when placement is off or there
// is nowhere to place.
void Launch::place()
{
    if (!o_.placement) return;
    placement_ = afm::Placement(afm::allowed_cpus(), afm::Placement::kLockDir);
    if (placement_.on() && !afm::pin_self(placement_.observers()))
        std::fprintf(stderr, "afm_launch: cannot pin the launcher to CPUs %s: %s\n", afm::cpu_list(placement_.observers()).c_str(),
                     std::strerror(errno));
}

nlohmann::json Launch::placement_json() const
{
    if (!placement_.on()) return {{"on", false}, {"why", placement_.why()}};
    return {{"on", true}, {"lockstep_cpus", afm::cpu_list(placement_.lockstep())}, {"observer_cpus", afm::cpu_list(placement_.observers())}};
}

void Launch::supervise()
{
    bool started = false;
    auto last_print = std::chrono::steady_clock::now() - std::chrono::seconds(10);
    auto last_check = last_print;
    while (true) {
        // a record with unwritten messages waits 1 ms for the next one: a
        // quiet bus (the simulator waiting for the record) flushes it
        const int got = pump(recorder_ && recorder_->unflushed() ? 1 : 20);
        if (!record(got == 0)) break;
        // then let a batch gather: a wake-up per datagram costs more
        // than the datagram (docs/bus.md, "The latency model")
        if (got > 0) std::this_thread::sleep_for(std::chrono::microseconds(kBatchUs));
        if (started && loop_cpu_.size() == 1 && prog_.sim_loop_over(scene_.total_blocks())) loop_cpu_.push_back(sup_.cpu_reading());
        // the processes' state at most every 5 ms (a message wakes this
        // loop thousands of times a second)
        if (std::chrono::steady_clock::now() - last_check < std::chrono::milliseconds(5)) continue;
        last_check = std::chrono::steady_clock::now();
        if (!supervise_step(&started)) break;
        const auto now = std::chrono::steady_clock::now();
        if (!o_.quiet && now - last_print >= std::chrono::seconds(1)) {
            last_print = now;
            std::fprintf(stderr, "\r%s", prog_.line(scene_, started, wall_s()).c_str());
            std::fflush(stderr);
        }
    }
    if (!o_.quiet) std::fprintf(stderr, "\n");
}

// One look at the processes: false when the run is over (done, failed,
// stalled or interrupted).
bool Launch::supervise_step(bool *started)
{
    if (g_signal) {
        interrupted_ = g_signal;
        failure_ = std::string("interrupted by ") + (g_signal == SIGINT ? "SIGINT" : "SIGTERM");
        return false;
    }
    sup_.reap();
    failure_ = sup_.dead(prog_, out_);
    if (!failure_.empty()) return false;
    if (sup_.all_exited()) {
        finished_ = true;
        return false;
    }
    if (o_.kill_after >= 0 && wall_s() >= o_.kill_after) {
        sup_.kill_named(o_.kill_name);
        o_.kill_after = -1;
    }
    // Start the run once every process is ready.
    if (!*started) {
        const auto names = sup_.names();
        if (std::all_of(names.begin(), names.end(), [&](const std::string &n) { return prog_.is(n, afm::RunState::ready); })) {
            *started = true;
            start_run();
        }
    }
    if (*started && !prog_.is("sim_afm", afm::RunState::done)) life_->running(0, 0, 200000);
    failure_ = stalled_process();
    return failure_.empty();
}

// Every process is ready: where each one really runs, their progress
// counted from now, the loop's first CPU reading.
void Launch::start_run()
{
    sup_.read_cpus();
    prog_.restart_clocks(std::chrono::steady_clock::now());
    loop_cpu_.push_back(sup_.cpu_reading());
}

// A live process whose heartbeats show no progress for --stall-s.
std::string Launch::stalled_process() const
{
    const std::string name = prog_.stalled(sup_.live(), o_.stall_s, wall0_, std::chrono::steady_clock::now());
    if (name.empty()) return "";
    return name + " made no progress for " + std::to_string(static_cast<int>(o_.stall_s)) + " s (log: " + out_ + "/logs/" + name + ".log)" +
           (hosts_.count == 2 ? "; the run is on two hosts: the link vhost-vafm (" + hosts_.asked +
                                    ") may have lost a message that has no resend (docs/hosts.md)"
                              : std::string());
}

// On failure, tell and then make everyone stop; the record last.
void Launch::stop()
{
    if (!failure_.empty()) {
        for (int i = 0; i < 3; ++i) {
            life_->stop(failure_);
            pump(20);
        }
        sup_.signal_run(SIGTERM);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (std::chrono::steady_clock::now() < deadline && !sup_.all_exited()) {
        for (auto &c : sup_.run()) c.reap();
        record(pump(20) == 0);
    }
    sup_.kill_run();
    drain();
    if (hosts_.count == 2) hosts_.stop_shapers();
    if (recorder_) recorded_events_ = recorder_->events();
    recorder_.reset();
    sup_.stop_view_bridge();
    // lcm-spy stays open for the person watching (the bus is quiet now);
    // the run ends when they close it, or on SIGINT or SIGTERM (however
    // soon it comes). On failure it is closed with the rest.
    if (o_.spy) sup_.close_spy(!failure_.empty());
    wall_ = wall_s();
}

// The messages still under way (kQuietMs), then the rest of the record to
// the file (a full disk fails the run here too).
void Launch::drain()
{
    const auto drain_end = std::chrono::steady_clock::now() + std::chrono::milliseconds(kDrainMs);
    while (std::chrono::steady_clock::now() < drain_end) {
        const int got = pump(kQuietMs);
        if (!record(got == 0) || got == 0) break;
    }
    record(true);
}

int Launch::finish()
{
    const nlohmann::json run = assemble(parts(), &messages_);
    if (const std::string why = write_record(out_, run); !why.empty()) {
        std::fprintf(stderr, "afm_launch: %s\n", why.c_str());
        return 1;
    }
    if (interrupted_) {
        std::fprintf(stderr, "run: %s; every process stopped, the bus log and run.json (status: interrupted) are kept in %s\n",
                     failure_.c_str(), out_.c_str());
        return 128 + interrupted_;
    }
    if (!failure_.empty()) {
        std::fprintf(stderr, "run: FAILED: %s\n", failure_.c_str());
        for (const auto &c : sup_.run())
            if (c.exit_code != 0)
                std::fprintf(stderr, "  %s exit code %d; last lines of its log:\n%s", c.name.c_str(), c.exit_code,
                             slurp_tail(out_ + "/logs/" + c.name + ".log", 5).c_str());
        std::fprintf(stderr, "run: the bus log and run.json are kept in %s\n", out_.c_str());
        return 1;
    }
    if (!finished_) return 1;
    print_summary(run, wall_, messages_, hosts_.count == 2 ? hosts_.summary() : "", out_);
    return run["verdict"]["pass"].get<bool>() || o_.no_verdict ? afm::kExitOk : afm::kExitVerdict;
}

// What run.json is made of besides the run's folder.
RunParts Launch::parts() const
{
    RunParts p;
    p.out = out_;
    p.scene_abs = scene_abs_;
    p.scene_hash = scene_hash_;
    p.scene = &scene_;
    p.failure = failure_;
    p.interrupted = interrupted_;
    const char *ns_mode = std::getenv("AFM_NETNS_MODE");
    p.netns = ns_mode ? ns_mode : "unknown";
    p.bus_url = bus_url();
    p.sim_seconds = prog_.sim_seconds();
    p.wall_seconds = wall_;
    for (const auto &c : sup_.run()) {
        p.processes.push_back(process_json(c));
        p.processes.back()["host"] = hosts_.count == 2 ? hosts_.where(c.name) : "one";
    }
    p.hosts = hosts_.json(sup_.names());
    p.launcher = launcher_json();
    p.placement = placement_json();
    p.provenance = provenance((fs::path(exe_dir()) / ".." / "provenance.json").string());
    p.loop_cpu = loop_cpu_;
    return p;
}

// run.json launcher.view_bridge: null without --view-fd; else its exit
// code, log and the kernel's accounting, and its report (what it passed
// on and refused, afm_view_bridge's contract), or report_error.
nlohmann::json Launch::view_bridge_json() const
{
    const Child *b = sup_.observer("view_bridge");
    if (!b || b->pid <= 0) return nullptr;
    nlohmann::json j = process_json(*b);
    std::ifstream f(out_ + "/" + kViewBridgeReport);
    const nlohmann::json rep = f ? nlohmann::json::parse(f, nullptr, false) : nlohmann::json();
    if (rep.is_object()) j.update(rep);
    else j["report_error"] = std::string(kViewBridgeReport) + (f ? ": not a JSON object" : ": missing");
    return j;
}

// The launcher itself (run.json "launcher"): it records the bus
// (bus_recorder.hpp), so its share of the machine is part of a run's cost.
nlohmann::json Launch::launcher_json() const
{
    struct rusage ru {};
    getrusage(RUSAGE_SELF, &ru);
    return {{"rejected", inbox_ ? inbox_->rejected().to_json() : nlohmann::json(nullptr)},
            {"recorded_events", recorded_events_},
            {"tap_dropped", tap_ ? tap_->dropped() : 0},       // datagrams no LCM message (bus_tap.hpp)
            {"tap_abandoned", tap_ ? tap_->abandoned() : 0},   // fragmented messages left unfinished
            {"unproven", tap_ ? tap_->unproven().to_json() : afm::ProofCounts().to_json()},   // without the run's proof (bus_key.hpp)
            {"proof_cost", afm::proof_cost().to_json()},
            {"bus_mac", key_fd_ >= 0},
            {"foreign_datagrams", senders_ ? senders_->foreign_count() : 0},   // from no process that publishes their channel
            {"foreign", senders_ ? senders_->foreign() : nlohmann::json::object()},
            {"view_bridge", view_bridge_json()},
            {"tap_receive_buffer_bytes", tap_ ? tap_->receive_buffer_bytes() : 0},
            {"log_window_blocks", log_window_},
            {"cpu_user_s", ru.ru_utime.tv_sec + ru.ru_utime.tv_usec * 1e-6},
            {"cpu_system_s", ru.ru_stime.tv_sec + ru.ru_stime.tv_usec * 1e-6},
            {"max_rss_kb", ru.ru_maxrss}};
}

// Waits up to timeout_ms for the bus, then takes everything it holds:
// every message into the record, and each to the launcher's inbox (the
// heartbeats). Returns the messages taken.
int Launch::pump(int timeout_ms)
{
    if (!tap_->wait(timeout_ms)) return 0;
    return tap_->drain([this](const std::string &channel, const unsigned char *data, std::size_t size, int64_t utime) {
        if (recorder_ && record_error_.empty()) {
            try {
                recorder_->take(channel, data, size, utime);
            } catch (const afm::LogError &e) {
                record_error_ = e.what();   // record() fails the run with it
            }
        }
        inbox_->deliver(channel, data, size);
    });
}

// Settles the record after pump() (bus_quiet: the wait for a message
// timed out); false (failure_ set) when the record cannot be written.
bool Launch::record(bool bus_quiet)
{
    if (!recorder_) return true;
    try {
        if (!record_error_.empty()) throw afm::LogError(record_error_);
        recorder_->settle(bus_quiet);
        return true;
    } catch (const afm::LogError &e) {
        if (failure_.empty()) failure_ = e.what();
        recorder_.reset();
        return false;
    }
}

double Launch::wall_s() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count(); }

// The bus's URL for this run: ttl=0 on one namespace, ttl=1 across the link of two hosts.
const char *Launch::bus_url() const { return hosts_.count == 2 ? afm::kLinkBusUrl : afm::kBusUrl; }

}  // namespace afm::launch
