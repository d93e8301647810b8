// Launch: how afm_launch runs one scene (launch/main.cpp). Validates the scene before starting anything,
// checks that it sits in a private network namespace whose loopback carries
// the multicast route (./afm run puts it there), records the whole bus
// itself (bus_recorder.hpp), starts the four processes (and, with --view-fd, the page's bridge,
// afm_view_bridge, with the run's key), prints progress, stops everything
// at the end (or when one dies), and writes DIR/run.json.
#pragma once

#include <lcm/lcm-cpp.hpp>
#include <lcm/lcm.h>

#include <fcntl.h>
#include <spawn.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "afm/analog_block_t.hpp"
#include "afm/heartbeat_t.hpp"
#include "afm/haptic_pose_t.hpp"
extern "C" {
#include "fw_guard.h"
}
#include "bus_key.hpp"
#include "bus_recorder.hpp"
#include "bus_tap.hpp"
#include "senders.hpp"
#include "lcmlog.hpp"
#include "log_tail.hpp"
#include "placement.hpp"
#include "bus.hpp"
#include "inbox.hpp"
#include <nlohmann/json.hpp>
#include "card_setup.hpp"
#include "haptic.hpp"
#include "scene.hpp"

#include "children.hpp"
#include "hosts.hpp"
#include "verdict.hpp"
#include "warnings.hpp"

namespace fs = std::filesystem;

namespace afm::launch {

// run.json's layout: docs/design.md's table of keys is held to a run's
// keys by tests/e2e/test_contract.py. 2: schema_version, provenance, scene_hash.
constexpr int kRunSchemaVersion = 2;

inline const char *kUsage =
    "usage: afm_launch --scene FILE --out DIR [options]\n"
    "  Runs one scene through sim_afm, fw_node, operator and renderer on a private\n"
    "  LCM bus, recording it to DIR/bus.lcmlog. ./afm run calls it inside a fresh\n"
    "  network namespace; run directly it refuses unless loopback carries the\n"
    "  multicast route.\n"
    "options:\n"
    "  --check            validate the scene and exit (0: valid, 2: not)\n"
    "  --spy              also start lcm-spy on the run's bus (needs DISPLAY); the run\n"
    "                     starts once lcm-spy listens on the bus (10 s at most) and ends\n"
    "                     when lcm-spy is closed (time_mode: realtime to watch at pace)\n"
    "  --view             the renderer also publishes its frames on VIEW_FRAME for a page\n"
    "                     (./afm run --view serves it; docs/view.md)\n"
    "  --view-fd N        with --view: start afm_view_bridge, the launcher's child with the\n"
    "                     run's key, writing VIEW_FRAME and AFM_HEARTBEAT to descriptor N (the\n"
    "                     pipe to the page's server, which ./afm run --view hands down)\n"
    "  --inject-drop P    sim_afm drops each analog block's first send with probability P\n"
    "  --kill AFTER_S:NAME  failure injection: SIGKILL process NAME AFTER_S wall seconds into the run\n"
    "  --inject-crash fw_node:N  failure injection: fw_node exits (code 70) on analog block N\n"
    "  --firmware host|qemu  where the card runs: linked into fw_node (host, the default) or\n"
    "                     built for its processor on an emulated mps2-an386 board (docs/pil.md)\n"
    "  --hosts 1|2        one network namespace (the default), or the paper's two computers: sim_afm in\n"
    "                     \"afm\", the rest in \"host\", joined by a veth pair and its link (./afm run\n"
    "                     --hosts 2 [--link SPEC] makes them: run/two_hosts.sh, docs/hosts.md)\n"
    "  --stall-s S        abort if the run makes no progress for S wall seconds (default 60)\n"
    "  --quiet            no progress line (with --check: no warnings, only refusals)\n"
    "  --strict           a warning about the scene (host_bridge/launch/warnings.hpp) is an error\n"
    "  --no-verdict       exit 0 when the run completes but fails one of its own checks\n"
    "                     (the verdict is still in run.json and the last line; else exit 4)\n"
    "bench options (./afm bench bus):\n"
    "  --log-window N     sim_afm runs at most N blocks ahead of what the record holds\n"
    "                     (default: as many as the record's receive buffer holds at\n"
    "                     32 kB a block, 8 to 64; run.json launcher.log_window_blocks);\n"
    "                     0: no pacing\n"
    "  --no-renderer      no renderer: no frames, no video, no fidelity check\n"
    "  --placement off    no CPU placement (default on: sim_afm, fw_node and operator share\n"
    "                     one CPU, the launcher and the renderer run on the others;\n"
    "                     common/placement.hpp)\n";

// SIGINT or SIGTERM to the launcher: the run stops as on a failure (every
// child stopped, the record closed, run.json written) with status
// "interrupted", and the launcher exits with 128 + the signal.
inline volatile sig_atomic_t g_signal = 0;
inline void on_stop_signal(int sig) { g_signal = sig; }

// The bus processes run at a lower priority than the launcher, which
// records the bus, so that on a busy machine the record keeps up and the run
// slows down instead.
constexpr int kBusProcessNice = 10;

// After a datagram wakes the launcher, it sleeps this long before it records
// the next ones, so that it records a block's datagrams in one wake-up, not
// eight (the simulator's log window, log_window_blocks(), is 8 to 64 blocks;
// ./afm bench bus measures it).
constexpr int kBatchUs = 500;

// Once every process has exited, what they sent is in the tap's socket or a
// softirq away from it (loopback delivers in the sender's system call, or
// on ksoftirqd soon after): the record takes the bus until it has been
// quiet for kQuietMs, at most kDrainMs, and is closed. (A fixed 150 ms was
// a quarter of the demo's wall time.)
constexpr int kQuietMs = 20;
constexpr int kDrainMs = 150;
constexpr double kSpyWaitS = 10.0;   // --spy: the longest the run waits for lcm-spy to listen

inline std::string exe_dir()
{
    return fs::canonical("/proc/self/exe").parent_path().string();
}

// afm_view_bridge (host_bridge/view), built beside the launcher.
inline std::string view_bridge_path()
{
    return exe_dir() + "/afm_view_bridge";
}

// Whether the planner can serve the scene's targets (pattern.hpp), asked of
// the operator, which owns the planner: `operator --check-targets` prints
// the refusal itself. The launcher does not link OpenCV (the text and PNG
// patterns need it) so that it starts in a few ms, not 60: it is on the path
// of every run. Returns -1 if they can be served, else 2 (said on stderr).
inline int check_targets(const std::string &scene_path)
{
    const std::string op = exe_dir() + "/operator";
    std::vector<char *> a = {const_cast<char *>(op.c_str()), const_cast<char *>("--scene"), const_cast<char *>(scene_path.c_str()),
                             const_cast<char *>("--check-targets"), nullptr};
    pid_t pid = -1;
    if (const int e = posix_spawn(&pid, op.c_str(), nullptr, nullptr, a.data(), environ); e != 0) {
        std::fprintf(stderr, "afm_launch: cannot check the planner's targets: cannot execute %s: %s\n", op.c_str(), std::strerror(e));
        return 2;
    }
    int status = 0;
    while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {}
    if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return -1;
    if (!(WIFEXITED(status) && WEXITSTATUS(status) == 2))
        std::fprintf(stderr, "afm_launch: cannot check the planner's targets: %s --check-targets %s\n", op.c_str(),
                     WIFEXITED(status) ? ("exited " + std::to_string(WEXITSTATUS(status))).c_str()
                                       : ("died of signal " + std::to_string(WTERMSIG(status))).c_str());
    return 2;
}

// The distinct blocks of the card's two per-block inputs in a log (their
// seq, through the bus's own decode-and-check): a block the replay can step
// needs both.
struct RecordedBlocks {
    std::set<int64_t> analog, pose;
};

// Message counts per channel in an LCM log, and the blocks recorded.
inline std::map<std::string, int64_t> count_channels(const std::string &path, std::string *err, RecordedBlocks *seqs)
{
    std::map<std::string, int64_t> counts;
    try {
        afm::LogReader log(path);
        afm::LogEvent ev;
        while (log.read(&ev)) {
            ++counts[ev.channel];
            afm::analog_block_t b;
            afm::haptic_pose_t p;
            if (ev.channel == AFM_CH_AFM_ANALOG && afm::decode_checked(ev.data.data(), ev.data.size(), &b) == afm::Reject::none)
                seqs->analog.insert(b.seq);
            if (ev.channel == AFM_CH_HAPTIC_POSE && afm::decode_checked(ev.data.data(), ev.data.size(), &p) == afm::Reject::none)
                seqs->pose.insert(p.seq);
        }
    } catch (const afm::LogError &e) {
        *err = e.what();
    }
    return counts;
}

// The command line.
struct Options {
    std::string scene_path, out_dir;
    bool spy = false, quiet = false, check_only = false, no_verdict = false, strict = false;
    bool view = false;          // the renderer publishes VIEW_FRAME (docs/view.md)
    int view_fd = -1;           // --view-fd: the pipe afm_view_bridge writes to (-1: no bridge)
    double drop_p = 0, stall_s = 60, kill_after = -1;
    std::string kill_name;
    long long crash_block = -1;
    std::string firmware = "host";   // fw_node --firmware: host, or qemu (the card on its board, docs/pil.md)
    long long log_window = -1;  // sim_afm --log-window; 0: no --follow-log; -1: log_window_blocks() of the tap's buffer
    bool renderer = true;
    bool placement = true;      // common/placement.hpp; --placement off
    int hosts = 1;              // 2: the two computers on a link (hosts.hpp)
};

// Parses argv into o; returns -1 to go on, or the exit code.
// A flag without a value (--spy, --view, ...): sets it and says so.
inline bool set_flag(const std::string &a, Options *o)
{
    static const std::map<std::string, bool Options::*> flags = {
        {"--spy", &Options::spy},           {"--view", &Options::view},          {"--check", &Options::check_only},
        {"--quiet", &Options::quiet},       {"--no-verdict", &Options::no_verdict}, {"--strict", &Options::strict}};
    const auto it = flags.find(a);
    if (it == flags.end()) return false;
    o->*(it->second) = true;
    return true;
}

// What the options say together (-1: go on, else the exit code).
inline int check_args(const Options *o)
{
    if (o->scene_path.empty() || (o->out_dir.empty() && !o->check_only)) {
        std::fputs(kUsage, stderr);
        return 2;
    }
    if (o->spy && !o->check_only && !std::getenv("DISPLAY")) {
        std::fprintf(stderr, "afm_launch: --spy needs a display and DISPLAY is not set (lcm-spy is a window)\n");
        return 2;
    }
    if (o->view_fd >= 0 && !o->view) {
        std::fprintf(stderr, "afm_launch: --view-fd goes with --view (it is the pipe to the page's server)\n");
        return 2;
    }
    if (o->view_fd >= 0 && access(view_bridge_path().c_str(), X_OK) != 0) {
        std::fprintf(stderr, "afm_launch: --view-fd: %s is missing: build the bench first (./afm build)\n", view_bridge_path().c_str());
        return 2;
    }
    if (!(o->drop_p >= 0 && o->drop_p < 1)) {
        std::fprintf(stderr, "afm_launch: --inject-drop must be in [0, 1), got %g\n", o->drop_p);
        return 2;
    }
    return -1;
}

// --view-fd N: a descriptor this process holds open for writing, above
// stdin, stdout and stderr. -1 when it is, else 2, said.
inline int parse_view_fd(const std::string &v, Options *o)
{
    char *end = nullptr;
    const long fd = std::strtol(v.c_str(), &end, 10);
    const int flags = !v.empty() && !*end && fd > 2 && fd < 1024 ? fcntl(static_cast<int>(fd), F_GETFL) : -1;
    if (flags < 0 || (flags & O_ACCMODE) == O_RDONLY) {
        std::fprintf(stderr, "afm_launch: --view-fd wants a descriptor above 2 open for writing, got '%s'\n", v.c_str());
        return 2;
    }
    o->view_fd = static_cast<int>(fd);
    return -1;
}

inline int parse_args(int argc, char **argv, Options *o)
{
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto val = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "afm_launch: %s needs a value\n", a.c_str());
                std::exit(2);
            }
            return argv[++i];
        };
        if (set_flag(a, o)) continue;
        if (a == "--scene") o->scene_path = val();
        else if (a == "--out") o->out_dir = val();
        else if (a == "--inject-drop") o->drop_p = std::atof(val().c_str());
        else if (a == "--firmware") {
            o->firmware = val();
            if (o->firmware != "host" && o->firmware != "qemu") {
                std::fprintf(stderr, "afm_launch: --firmware wants host or qemu, got '%s'\n", o->firmware.c_str());
                return 2;
            }
        }
        else if (a == "--stall-s") o->stall_s = std::atof(val().c_str());
        else if (a == "--log-window") {
            const std::string v = val();
            char *end = nullptr;
            o->log_window = std::strtoll(v.c_str(), &end, 10);
            if (v.empty() || *end || o->log_window < 0) {
                std::fprintf(stderr, "afm_launch: --log-window wants a number of blocks >= 0, got '%s'\n", v.c_str());
                return 2;
            }
        }
        else if (a == "--no-renderer") o->renderer = false;
        else if (a == "--view-fd") {
            if (const int code = parse_view_fd(val(), o); code >= 0) return code;
        }
        else if (a == "--hosts") {
            const std::string v = val();
            if (v != "1" && v != "2") {
                std::fprintf(stderr, "afm_launch: --hosts wants 1 or 2, got '%s'\n", v.c_str());
                return 2;
            }
            o->hosts = std::atoi(v.c_str());
        }
        else if (a == "--placement") {
            const std::string v = val();
            if (v != "on" && v != "off") {
                std::fprintf(stderr, "afm_launch: --placement wants on or off, got '%s'\n", v.c_str());
                return 2;
            }
            o->placement = v == "on";
        }
        else if (a == "--kill") {
            const std::string v = val();
            const auto colon = v.find(':');
            if (colon == std::string::npos) {
                std::fprintf(stderr, "afm_launch: --kill wants AFTER_S:NAME, got '%s'\n", v.c_str());
                return 2;
            }
            o->kill_after = std::atof(v.substr(0, colon).c_str());
            o->kill_name = v.substr(colon + 1);
        } else if (a == "--inject-crash") {
            const std::string v = val();
            if (v.rfind("fw_node:", 0) != 0) {
                std::fprintf(stderr, "afm_launch: --inject-crash supports fw_node:N, got '%s'\n", v.c_str());
                return 2;
            }
            o->crash_block = std::atoll(v.substr(8).c_str());
        } else if (a == "-h" || a == "--help") {
            std::fputs(kUsage, stdout);
            return 0;
        } else {
            std::fprintf(stderr, "afm_launch: unknown argument '%s'\n%s", a.c_str(), kUsage);
            return 2;
        }
    }
    return check_args(o);
}

// afm_view_bridge's report in the run's folder (run.json launcher.view_bridge).
inline constexpr const char *kViewBridgeReport = "view_bridge_report.json";

// The files an earlier run left in a folder that this run replaces.
const char *const kRunOutputs[] = {"frames", "logs", "bus.lcmlog", "run.json", "scene.yaml", "video.mp4", "video.avi",
                                   "sim_report.json", "renderer_report.json", "operator_report.json", "fw_report.json", "scan_initial.png",
                                   "contact_sheet.png", "scan_initial.gsf", "scan_final.gsf", "display_final.gsf",
                                   "fidelity.json", "fidelity_diff.png", kViewBridgeReport};

// One run: the steps of main, in order, sharing the run's state.
class Launch {
public:
    // --view-fd: kept from every process but afm_view_bridge (spawn hands it
    // to that one) and closed here once the bridge has it
    explicit Launch(Options o) : o_(std::move(o))
    {
        if (o_.view_fd >= 0) fcntl(o_.view_fd, F_SETFD, FD_CLOEXEC);
    }
    ~Launch()
    {
        mark_ended();
        if (o_.view_fd >= 0) close(o_.view_fd);
    }
    Launch(const Launch &) = delete;
    Launch &operator=(const Launch &) = delete;

    // -1 when --out is a folder a run may take (none, a run's, or new); else
    // 2, said. --check with --out asks only this of the folder, before
    // tools/in_netns.sh hands it to the run's user (issue 46).
    int check_out() const
    {
        const fs::path dir = o_.out_dir;
        std::error_code ec;
        if (dir.empty() || !fs::exists(dir, ec)) return -1;
        if (!fs::is_directory(fs::symlink_status(dir, ec)) ||
            (!only_a_lock(dir) && !fs::exists(dir / "run.json", ec) && !fs::exists(dir / "bus.lcmlog", ec))) {
            std::fprintf(stderr, "afm_launch: output folder %s exists and holds something that is not a run; choose another --out\n",
                         o_.out_dir.c_str());
            return 2;
        }
        // a run under way in it (its lock held): named here too (--check),
        // the lock opened read-only, no link followed, never created; not
        // when this run holds it already (prepare)
        if (lock_fd_ >= 0) return -1;
        const std::string path = (dir / kLockName).string();
        const int fd = open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC);
        if (fd < 0) return -1;
        struct stat st {};
        const bool busy = fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && flock(fd, LOCK_SH | LOCK_NB) != 0;
        if (busy) say_in_use(fd, path);
        close(fd);
        return busy ? 2 : -1;
    }

    // 1. The scene and the card's acceptance, before anything starts.
    int check_scene()
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
        // The force loop's stability bound (haptic.hpp) and the planner's targets.
        const afm::CardSetup card(scene_);
        if (const std::string why = afm::haptic_refusal(scene_, card.config()); !why.empty()) {
            std::fprintf(stderr, "%s: %s\n", o_.scene_path.c_str(), why.c_str());
            return 2;
        }
        if (!scene_.op.plan.enabled && !scene_.op.haptic.passivity_check && !(o_.check_only && o_.quiet)) {
            const afm::HapticBound b = afm::haptic_bound(scene_, card.config());
            if (!b.passive || !b.within_device)
                std::fprintf(stderr, "%s: warning: the force loop is outside its stability bound (K_r %.0f N/m, K_max %.0f N/m, the device's "
                             "limit %.0f N/m) and operator.haptic.passivity_check is false: the device's passivity controller will clamp it\n",
                             o_.scene_path.c_str(), b.rendered_N_per_m, b.max_rendered_N_per_m, scene_.op.haptic.max_stiffness_N_per_m);
        }
        const auto warnings = afm::scene_warnings(scene_, card.config());
        if (!(o_.check_only && o_.quiet) || o_.strict)
            for (const auto &w : warnings)
                std::fprintf(stderr, "%s: %s%s\n", o_.scene_path.c_str(), o_.strict ? "" : "warning: ", w.c_str());
        if (o_.strict && !warnings.empty()) return 2;
        if (scene_.op.plan.enabled) return check_targets(o_.scene_path);
        return -1;
    }

    // 2. The bus must stay on this namespace's loopback; 3. the run folder:
    // a fresh one, or an earlier run's (its outputs replaced), with a copy of
    // the scene that the run's processes read (what the run ran stays known:
    // replay reads it, while the original may change).
    int prepare()
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
        const fs::path dir = o_.out_dir;
        try {
            // the lock first: a run under way is named as such, whatever it has written yet
            if (fs::exists(dir) && fs::is_directory(dir)) {
                if (const int code = lock_out(dir); code >= 0) return code;
            }
            if (const int code = check_out(); code >= 0) return code;
            fs::create_directories(dir);
            if (lock_fd_ < 0)
                if (const int code = lock_out(dir); code >= 0) return code;
            for (const char *old : kRunOutputs) fs::remove_all(dir / old);
            fs::create_directories(dir / "logs");
            fs::create_directories(dir / "frames");
            for (const auto &e : fs::directory_iterator(dir))
                if (e.path().filename().string().rfind("scan_local_", 0) == 0) fs::remove(e.path());
            out_ = fs::canonical(dir).string();
            scene_abs_ = fs::canonical(o_.scene_path).string();
            scene_run_ = out_ + "/scene.yaml";
            const std::string text = afm::resolved_scene_text(scene_abs_);   // includes merged: it stands alone
            std::ofstream(scene_run_) << text;
            scene_hash_ = afm::scene_hash(text);
        } catch (const fs::filesystem_error &e) {
            std::fprintf(stderr, "afm_launch: cannot prepare output folder %s: %s\n", o_.out_dir.c_str(), e.what());
            return 2;
        }
        signal(SIGPIPE, SIG_IGN);
        struct sigaction sa {};
        sa.sa_handler = on_stop_signal;
        sigemptyset(&sa.sa_mask);
        sigaction(SIGINT, &sa, nullptr);
        sigaction(SIGTERM, &sa, nullptr);
        try {
            setenv("LCM_DEFAULT_URL", bus_url(), 1);
            lc_ = afm::open_bus();
        } catch (const std::exception &e) {
            std::fprintf(stderr, "afm_launch: %s\n", e.what());
            return 2;
        }
        if (!o_.renderer)   // ./afm bench bus: the lockstep without the renderer
            kids_.erase(std::remove_if(kids_.begin(), kids_.end(), [](const Child &c) { return c.name == "renderer"; }), kids_.end());
        prog_.names = {"launcher"};
        for (const auto &c : kids_) prog_.names.insert(c.name);
        if (const int code = open_tap(); code >= 0) return code;
        inbox_ = std::make_unique<afm::Inbox>(nullptr);   // fed by the tap (pump())
        inbox_->on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [this](const afm::heartbeat_t &m) { return prog_.on_hb(m); });
        hb_ = std::make_unique<afm::Heartbeat>(*lc_, "launcher");
        wall0_ = std::chrono::steady_clock::now();
        return -1;
    }

    // The run's bus key (bus_key.hpp: AFM_BUS_MAC=off, none), before the
    // tap that proves with it and the processes that inherit it; then the
    // tap, admitting the run's own senders. -1, or the exit code, said.
    int open_tap()
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

    // 4. The record first (the launcher's own, bus_recorder.hpp), so the
    // log holds the whole run; then the processes.
    int start()
    {
        if (g_signal) return interrupted_before_start();
        try {
            recorder_ = std::make_unique<afm::BusRecorder>(out_ + "/bus.lcmlog");
            hb_->send(afm::RunState::starting, 0, 0, std::string("recording the bus; ") + afm::kScenePrefix + scene_hash_);
            pump(0);
            recorder_->settle(true);
        } catch (const afm::LogError &e) {
            std::fprintf(stderr, "afm_launch: %s\n", e.what());
            return 1;
        }
        const std::string bin = exe_dir();
        const std::string url_env = std::string("LCM_DEFAULT_URL=") + bus_url();
        std::vector<std::string> sim_cmd = {bin + "/../sim_afm/sim_afm", "--scene", scene_run_, "--out", out_, "--inject-drop",
                                            std::to_string(o_.drop_p)};
        log_window_ = o_.log_window >= 0 ? o_.log_window : afm::log_window_blocks(tap_->receive_buffer_bytes());
        if (log_window_ > 0)
            sim_cmd.insert(sim_cmd.end(), {"--follow-log", out_ + "/bus.lcmlog", "--log-window", std::to_string(log_window_)});
        if (!o_.renderer) sim_cmd.push_back("--no-renderer");
        if (hosts_.resend_ms() > 0) sim_cmd.insert(sim_cmd.end(), {"--resend-ms", std::to_string(hosts_.resend_ms())});
        std::vector<std::string> fw_cmd = {bin + "/fw_node", "--scene", scene_run_, "--out", out_, "--crash-at-block",
                                           std::to_string(o_.crash_block), "--firmware", o_.firmware};
        place();
        std::vector<std::string> renderer_cmd = {bin + "/renderer", "--scene", scene_run_, "--out", out_};
        if (o_.view) renderer_cmd.push_back("--view-frames");
        if (placement_.on()) {
            // the threads that publish aside (common/aside.hpp) and the frame
            // writer (frame_writer.hpp) on any CPU of the run: the kernel puts
            // them where there is room (the observers' CPU is the run's busiest)
            for (auto *cmd : {&sim_cmd, &fw_cmd}) cmd->insert(cmd->end(), {"--aside-cpus", afm::cpu_list(placement_.all())});
            renderer_cmd.insert(renderer_cmd.end(), {"--writer-cpus", afm::cpu_list(placement_.all())});
        }
        const std::map<std::string, std::vector<std::string>> cmds = {
            {"sim_afm", sim_cmd},
            {"fw_node", fw_cmd},
            {"operator", {bin + "/operator", "--scene", scene_run_, "--out", out_}},
            {"renderer", renderer_cmd},
        };
        if (o_.spy) start_spy(url_env);
        if (o_.view_fd >= 0) start_view_bridge();
        for (auto &c : kids_) c.pid = spawn_in_run(c.name, cmds.at(c.name));
        return -1;
    }

    // A process of the run, started as each one is: its output to
    // logs/NAME.log, the bus's URL, below the launcher's priority, on its
    // CPUs, with the run's key (and pass_fd: spawn). Two hosts: in the run's
    // inner user namespace (the afm namespace's owner), so that they read
    // one another's sockets, and its network namespace too where NAME runs
    // there; it drops what entering gave (tools/drop_caps.sh); the
    // launcher's ports said in its stead.
    pid_t spawn_in_run(const std::string &name, std::vector<std::string> cmd, int pass_fd = -1) const
    {
        std::vector<std::string> env = {std::string("LCM_DEFAULT_URL=") + bus_url()};
        Entry entry;
        if (hosts_.count == 2) {
            env.insert(env.end(), {hosts_.bus_link_env(name), std::string(afm::Senders::kParentPortsEnv) + "=" + afm::Senders::own_ports()});
            cmd.insert(cmd.begin(), hosts_.drop_caps);
            entry = {hosts_.afm_ns_pid, hosts_.on_afm(name)};
        }
        return spawn(cmd, out_ + "/logs/" + name + ".log", env, kBusProcessNice, placement_.cpus_for(name), entry, key_fd_, pass_fd);
    }

    // afm_view_bridge (--view-fd; docs/view.md), before the run's processes
    // so that it hears their first messages: an observer started as they
    // are (spawn_in_run), holding the run's key, the pipe handed down at
    // kPassedFd and closed here. It is stopped once they are done
    // (stop_view_bridge).
    void start_view_bridge()
    {
        view_bridge_.pid = spawn_in_run(view_bridge_.name, {view_bridge_path(), "--fd", std::to_string(kPassedFd), "--report",
                                                            out_ + "/" + kViewBridgeReport},
                                        o_.view_fd);
        close(o_.view_fd);
        o_.view_fd = -1;
    }

    // SIGTERM to afm_view_bridge: it passes on what its socket still holds,
    // says in its log what it refused, writes its report and ends; SIGKILL
    // after kViewBridgeStopMs (a pipe whose reader stopped reading).
    void stop_view_bridge()
    {
        if (view_bridge_.pid <= 0) return;
        view_bridge_.reap();
        if (!view_bridge_.exited) kill(view_bridge_.pid, SIGTERM);
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kViewBridgeStopMs);
        while (!view_bridge_.exited && std::chrono::steady_clock::now() < deadline) {
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
            view_bridge_.reap();
        }
        if (!view_bridge_.exited) kill(view_bridge_.pid, SIGKILL);
        view_bridge_.reap(true);
    }

    // run.json launcher.view_bridge: null without --view-fd; else its exit
    // code, log and the kernel's accounting, and its report (what it passed
    // on and refused, afm_view_bridge's contract), or report_error.
    nlohmann::json view_bridge_json() const
    {
        if (view_bridge_.pid <= 0) return nullptr;
        nlohmann::json j = process_json(view_bridge_);
        std::ifstream f(out_ + "/" + kViewBridgeReport);
        const nlohmann::json rep = f ? nlohmann::json::parse(f, nullptr, false) : nlohmann::json();
        if (rep.is_object()) j.update(rep);
        else j["report_error"] = std::string(kViewBridgeReport) + (f ? ": not a JSON object" : ": missing");
        return j;
    }

    // lcm-spy, before the run's processes: an LCM subscription sends
    // nothing, so the run holds its start until lcm-spy's socket is bound
    // on the bus's port in this namespace (a new one in /proc/net/udp*), or
    // kSpyWaitS at most; a lockstep run would otherwise end before it listens.
    void start_spy(const std::string &url_env)
    {
        const int before = udp_sockets_on_port(afm::kBusPort);
        spy_.pid = spawn({std::string(AFM_LCM_BIN) + "/lcm-spy", "--lcm-url=" + std::string(bus_url())}, out_ + "/logs/lcm-spy.log",
                         {url_env, std::string("CLASSPATH=") + AFM_TYPES_JAR}, 0, placement_.cpus_for("lcm-spy"));
        const auto t0 = std::chrono::steady_clock::now();
        while (udp_sockets_on_port(afm::kBusPort) <= before && !g_signal) {
            spy_.reap();
            const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            if (spy_.exited || waited >= kSpyWaitS) {
                std::fprintf(stderr, "afm_launch: lcm-spy %s; the run starts without it listening (logs/lcm-spy.log)\n",
                             spy_.exited ? "ended" : "did not bind the bus's port within 10 s");
                return;
            }
            pump(20);   // the record goes on meanwhile
        }
        if (!o_.quiet) std::fprintf(stderr, "afm_launch: lcm-spy listens on the bus; the run starts\n");
    }

    // The lockstep's CPU and the observers' (common/placement.hpp); the
    // launcher is an observer. Nothing pinned when placement is off or
    // there is nowhere to place.
    void place()
    {
        if (!o_.placement) return;
        placement_ = afm::Placement(afm::allowed_cpus(), afm::Placement::kLockDir);
        if (placement_.on() && !afm::pin_self(placement_.observers()))
            std::fprintf(stderr, "afm_launch: cannot pin the launcher to CPUs %s: %s\n", afm::cpu_list(placement_.observers()).c_str(),
                         std::strerror(errno));
    }

    nlohmann::json placement_json() const
    {
        if (!placement_.on()) return {{"on", false}, {"why", placement_.why()}};
        return {{"on", true}, {"lockstep_cpus", afm::cpu_list(placement_.lockstep())},
                {"observer_cpus", afm::cpu_list(placement_.observers())}};
    }

    // 5. Supervise until every process is done, or one fails or stalls.
    void supervise()
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
            if (started && loop_cpu_taken_ == 1 && sim_loop_over()) take_loop_cpu();
            // the processes' state at most every 5 ms (a message wakes this
            // loop thousands of times a second)
            if (std::chrono::steady_clock::now() - last_check < std::chrono::milliseconds(5)) continue;
            last_check = std::chrono::steady_clock::now();
            if (g_signal) {
                interrupted_ = g_signal;
                failure_ = std::string("interrupted by ") + (g_signal == SIGINT ? "SIGINT" : "SIGTERM");
                break;
            }
            for (auto &c : kids_) c.reap();
            spy_.reap();
            failure_ = dead_process();
            if (!failure_.empty()) break;
            if (std::all_of(kids_.begin(), kids_.end(), [](const Child &c) { return c.exited; })) {
                finished_ = true;
                break;
            }
            if (o_.kill_after >= 0 && wall_s() >= o_.kill_after) {
                for (auto &c : kids_)
                    if (c.name == o_.kill_name && !c.exited) kill(c.pid, SIGKILL);
                o_.kill_after = -1;
            }
            // Start the run once every process is ready.
            if (!started && std::all_of(kids_.begin(), kids_.end(), [&](const Child &c) { return prog_.is(c.name, afm::RunState::ready); })) {
                started = true;
                for (auto &c : kids_) c.cpus = afm::cpu_list(afm::cpus_of(c.pid));   // where each one really runs
                if (view_bridge_.pid > 0) view_bridge_.cpus = afm::cpu_list(afm::cpus_of(view_bridge_.pid));
                for (auto &kv : prog_.progress_at) kv.second = std::chrono::steady_clock::now();
                take_loop_cpu();
            }
            if (started && !prog_.is("sim_afm", afm::RunState::done)) hb_->maybe_send(afm::RunState::running, 0, 0, 200000);
            failure_ = stalled_process();
            if (!failure_.empty()) break;
            const auto now = std::chrono::steady_clock::now();
            if (!o_.quiet && now - last_print >= std::chrono::seconds(1)) {
                last_print = now;
                print_progress(started);
            }
        }
        if (!o_.quiet) std::fprintf(stderr, "\n");
    }

    // 6. Stop: on failure, tell and then make everyone stop; the record last.
    void stop()
    {
        auto signal_child = [](Child &c, int sig) {
            if (!c.exited && c.pid > 0) kill(c.pid, sig);
        };
        if (!failure_.empty()) {
            for (int i = 0; i < 3; ++i) {
                hb_->send(afm::RunState::stop, 0, 0, failure_);
                pump(20);
            }
            for (auto &c : kids_) signal_child(c, SIGTERM);
        }
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
        while (std::chrono::steady_clock::now() < deadline &&
               !std::all_of(kids_.begin(), kids_.end(), [](const Child &c) { return c.exited; })) {
            for (auto &c : kids_) c.reap();
            record(pump(20) == 0);
        }
        for (auto &c : kids_) {
            signal_child(c, SIGKILL);
            c.reap(true);
        }
        // the messages still under way (kQuietMs), then the record is closed
        const auto drain_end = std::chrono::steady_clock::now() + std::chrono::milliseconds(kDrainMs);
        while (std::chrono::steady_clock::now() < drain_end) {
            const int got = pump(kQuietMs);
            if (!record(got == 0) || got == 0) break;
        }
        record(true);   // the rest to the file (a full disk fails the run here too)
        if (hosts_.count == 2) hosts_.stop_shapers();
        if (recorder_) recorded_events_ = recorder_->events();
        recorder_.reset();
        stop_view_bridge();
        // lcm-spy stays open for the person watching (the bus is quiet now);
        // the run ends when they close it, or on SIGINT or SIGTERM (however
        // soon it comes). On failure it is closed with the rest.
        if (o_.spy && !spy_.exited) {
            if (failure_.empty()) std::fprintf(stderr, "run: the run is over; close lcm-spy to finish\n");
            else signal_child(spy_, SIGTERM);
            while (!spy_.exited && !g_signal) {
                spy_.reap();
                std::this_thread::sleep_for(std::chrono::milliseconds(50));
            }
            if (!spy_.exited) signal_child(spy_, SIGTERM);
            spy_.reap(true);
        }
        wall_ = wall_s();
    }

    // 7. run.json, then the summary; the exit code.
    int finish()
    {
        const nlohmann::json run = run_json();
        if (!write_run_json(run)) return 1;
        if (interrupted_) {
            std::fprintf(stderr, "run: %s; every process stopped, the bus log and run.json (status: interrupted) are kept in %s\n",
                         failure_.c_str(), out_.c_str());
            return 128 + interrupted_;
        }
        if (!failure_.empty()) {
            std::fprintf(stderr, "run: FAILED: %s\n", failure_.c_str());
            for (const auto &c : kids_)
                if (c.exit_code != 0)
                    std::fprintf(stderr, "  %s exit code %d; last lines of its log:\n%s", c.name.c_str(), c.exit_code,
                                 slurp_tail(out_ + "/logs/" + c.name + ".log", 5).c_str());
            std::fprintf(stderr, "run: the bus log and run.json are kept in %s\n", out_.c_str());
            return 1;
        }
        if (!finished_) return 1;
        const double sim_s = run["sim_seconds"].get<double>();
        std::printf("run: ok: %.2f simulated s in %.2f wall s (%.2f sim s per wall s), %d frames, %lld bus messages\n", sim_s, wall_,
                    wall_ > 0 ? sim_s / wall_ : 0.0, run["frames"].get<int>(), static_cast<long long>(messages_));
        if (run["timing"]["loop_realtime_factor"].is_number())
            std::printf("run: the loop, first block to last: %.2f wall s, %.1f us a block, %.2f x real time (the rest of the run: %.2f s)\n",
                        run["timing"]["loop_seconds"].get<double>(), run["timing"]["loop_us_per_block"].get<double>(),
                        run["timing"]["loop_realtime_factor"].get<double>(), run["timing"]["outside_loop_seconds"].get<double>());
        if (run.contains("fidelity")) {
            const auto &fj = run["fidelity"];
            // null: an object the display shows was not found in the scan (an infinite error)
            auto num = [&](const char *k) { return fj.contains(k) && fj[k].is_number() ? fj[k].get<double>() : -1.0; };
            const double max_err = num("max_position_error_nm");
            char err[64];
            if (max_err >= 0) std::snprintf(err, sizeof err, "%.2f nm", max_err);
            else std::snprintf(err, sizeof err, "(an object not found in the scan)");
            std::printf("run: fidelity (display vs a fresh scan at frame %d): max object position error %s, RMS height "
                        "difference %.2f nm (%s)\n",
                        fj.value("frame", 0), err, num("rms_height_error_nm"), fj.value("pass", false) ? "within target" : "OUTSIDE the 5 nm target");
        }
        print_plan(run);
        print_board(run);
        print_view_bridge(run["launcher"]["view_bridge"]);
        if (hosts_.count == 2)
            std::printf("%s; the simulator resent %lld blocks\n", hosts_.summary().c_str(),
                        static_cast<long long>(run.contains("sim") ? run["sim"].value("resends", 0L) : 0L));
        std::printf("run: output in %s\n", out_.c_str());
        std::printf("%s\n", verdict_line(run["verdict"]).c_str());
        return run["verdict"]["pass"].get<bool>() || o_.no_verdict ? afm::kExitOk : afm::kExitVerdict;
    }

private:
    // run.json whole or not at all: written beside, then renamed over (a
    // full disk leaves no half-written file that a reader could take for a
    // finished run).
    // What made this build (build/main/provenance.json, written at every
    // build: cmake/provenance.cmake); null where it cannot be read.
    static nlohmann::json provenance()
    {
        std::ifstream f(fs::path(exe_dir()) / ".." / "provenance.json");
        if (!f) return nullptr;
        const auto j = nlohmann::json::parse(f, nullptr, false);
        return j.is_discarded() ? nlohmann::json(nullptr) : j;
    }

    bool write_run_json(const nlohmann::json &run) const
    {
        const std::string path = out_ + "/run.json", tmp = path + ".partial";
        {
            std::ofstream f(tmp);
            f << run.dump(2) << "\n";
            f.flush();
            if (!f) {
                std::error_code ec;
                fs::remove(tmp, ec);
                const int err = errno ? errno : EIO;
                std::fprintf(stderr, "afm_launch: cannot write %s: %s (status would have been '%s'%s%s)\n", path.c_str(),
                             std::strerror(err), run.value("status", "?").c_str(), run.contains("error") ? ": " : "",
                             run.contains("error") ? run["error"].get<std::string>().c_str() : "");
                return false;
            }
        }
        std::error_code ec;
        fs::rename(tmp, path, ec);
        if (ec) {
            fs::remove(tmp, ec);
            std::fprintf(stderr, "afm_launch: cannot write %s: %s\n", path.c_str(), ec.message().c_str());
            return false;
        }
        return true;
    }

    // A signal before the run started: nothing ran.
    int interrupted_before_start()
    {
        std::fprintf(stderr, "afm_launch: interrupted before the run started\n");
        return 128 + g_signal;
    }

    // The bus's URL for this run: ttl=0 on one namespace, ttl=1 across the link of two hosts.
    const char *bus_url() const { return hosts_.count == 2 ? afm::kLinkBusUrl : afm::kBusUrl; }

    Options o_;
    Hosts hosts_;
    afm::Scene scene_;
    // --out is locked for the run's life (flock on OUT/.afm-run.lock, which
    // names the run's pid): a second run into it is refused at once, naming
    // the one that holds it. The lock goes with this process, however it ends;
    // its record says "ended, pid N" once the launcher ended (~Launch), so a
    // "pid N" found by the next launcher is a run whose launcher was killed
    // (its processes went with it: children.hpp), said in one line.
    static constexpr const char *kLockName = ".afm-run.lock";
    int lock_fd_ = -1;
    int key_fd_ = -1;   // the run's bus key in a memfd, for the children (bus_key.hpp); -1: AFM_BUS_MAC=off

    static bool only_a_lock(const fs::path &dir)
    {
        for (const auto &e : fs::directory_iterator(dir))
            if (e.path().filename() != kLockName) return false;
        return true;
    }

    // "in use by another run", naming the pid its lock (fd, at path) holds.
    void say_in_use(int fd, const std::string &path) const
    {
        char holder[64] = {0};
        const ssize_t n = pread(fd, holder, sizeof holder - 1, 0);
        std::string who(holder, n > 0 ? static_cast<std::size_t>(n) : 0);
        while (!who.empty() && (who.back() == '\n' || who.back() == ' ')) who.pop_back();
        std::fprintf(stderr, "afm_launch: output folder %s is in use by another run (%s; its lock %s); choose another --out\n",
                     o_.out_dir.c_str(), who.empty() ? "pid unknown" : who.c_str(), path.c_str());
    }

    // -1 when the folder is ours now; else the exit code, said.
    int lock_out(const fs::path &dir)
    {
        const std::string path = (dir / kLockName).string();
        lock_fd_ = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (lock_fd_ < 0) {
            std::fprintf(stderr, "afm_launch: cannot lock the output folder %s: %s\n", o_.out_dir.c_str(), std::strerror(errno));
            return 2;
        }
        if (flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
            say_in_use(lock_fd_, path);
            return 2;
        }
        // the record of the last run in this folder: "pid N" while it ran,
        // "ended, pid N" once its launcher ended (~Launch); a "pid N" left
        // behind is a launcher that never ended (SIGKILL, a crash), and the
        // lock, now ours, says it is gone
        char last[64] = {0};
        const ssize_t got = pread(lock_fd_, last, sizeof last - 1, 0);
        const std::string was(last, got > 0 ? static_cast<std::size_t>(got) : 0);
        if (was.rfind("pid ", 0) == 0)
            std::fprintf(stderr, "afm_launch: the last run in %s was interrupted: its launcher (%s) ended without finishing it%s; this run replaces it\n",
                         o_.out_dir.c_str(), was.substr(0, was.find('\n')).c_str(),
                         fs::exists(dir / "run.json") ? "" : " and left no run.json");
        const std::string me = "pid " + std::to_string(getpid()) + "\n";
        if (ftruncate(lock_fd_, 0) != 0 || pwrite(lock_fd_, me.data(), me.size(), 0) != static_cast<ssize_t>(me.size()))
            std::fprintf(stderr, "afm_launch: warning: cannot write the lock %s's pid: %s\n", path.c_str(), std::strerror(errno));
        return -1;
    }

    // The lock's record says the run's launcher ended (however the run did).
    void mark_ended()
    {
        if (lock_fd_ < 0) return;
        const std::string rec = "ended, pid " + std::to_string(getpid()) + "\n";
        if (ftruncate(lock_fd_, 0) != 0 || pwrite(lock_fd_, rec.data(), rec.size(), 0) != static_cast<ssize_t>(rec.size())) {}
    }

    std::string out_, scene_abs_, scene_run_;
    std::string scene_hash_;   // afm::scene_hash of scene_run_'s text
    std::unique_ptr<lcm::LCM> lc_;
    std::unique_ptr<afm::Inbox> inbox_;
    std::unique_ptr<afm::Heartbeat> hb_;
    Progress prog_;
    std::chrono::steady_clock::time_point wall0_;
    std::unique_ptr<afm::BusTap> tap_;   // the whole bus, without liblcm's receive thread
    std::unique_ptr<afm::Senders> senders_;   // the tap's admitter: the run's own processes on their channels
    long long log_window_ = 0;           // the simulator's window on the record, blocks (0: none)
    std::unique_ptr<afm::BusRecorder> recorder_;
    std::string record_error_;   // a write into the record that failed inside pump()
    int64_t recorded_events_ = 0;   // what the record held when it was closed
    afm::Placement placement_;   // the lockstep's CPU and the observers' (place())
    Child spy_{"lcm-spy"};
    Child view_bridge_{"view_bridge"};   // afm_view_bridge (--view-fd)
    static constexpr int kViewBridgeStopMs = 2000;
    std::vector<Child> kids_ = {{"sim_afm"}, {"fw_node"}, {"operator"}, {"renderer"}};
    std::string failure_;
    bool finished_ = false;
    int interrupted_ = 0;   // the signal that stopped the run (0: none)
    double wall_ = 0;
    // Each process's CPU (s) with its descendants, and theirs apart (-1:
    // none alive), and the launcher's own, when the run started and when
    // the simulator's loop was over: what the loop cost each (run.json
    // timing.loop_cpu_us_per_block).
    struct LoopCpu {
        double total = -1, children = -1;
    };
    std::map<std::string, LoopCpu> loop_cpu_[2];
    int loop_cpu_taken_ = 0;
    // The simulator's loop is over: its heartbeat for the last block (sent
    // at once when the loop ends), or "done" (a run that ended early).
    bool sim_loop_over() const
    {
        const auto it = prog_.last.find("sim_afm");
        if (it == prog_.last.end()) return false;
        return it->second.state == afm::state_text(afm::RunState::done) || it->second.seq >= scene_.total_blocks() - 1;
    }
    void take_loop_cpu()
    {
        auto &m = loop_cpu_[loop_cpu_taken_++];
        for (const auto &c : kids_) {
            double below = 0;
            LoopCpu &x = m[c.name];
            x.total = c.exited ? c.cpu_user_s + c.cpu_system_s : tree_cpu_seconds(c.pid, &below);
            if (!c.exited && below > 0) x.children = below;
        }
        timespec ts{};
        clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
        m["afm_launch"].total = ts.tv_sec + ts.tv_nsec * 1e-9;
    }
    int64_t messages_ = 0;

    double wall_s() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0_).count(); }

    // A process that died before the simulator said done (or with an error).
    std::string dead_process() const
    {
        for (const auto &c : kids_) {
            if (!c.exited || (c.exit_code == 0 && (prog_.is("sim_afm", afm::RunState::done) || c.name == "sim_afm"))) continue;
            // A clean exit: the process heard the simulator's "done", which
            // this process may not have dispatched yet; given a moment.
            if (c.exit_code == 0 && std::chrono::steady_clock::now() - c.exited_at < std::chrono::milliseconds(500)) continue;
            std::string why = c.name + " died with exit code " + std::to_string(c.exit_code) + " (log: " + out_ + "/logs/" + c.name + ".log)";
            const std::string last = slurp_tail(out_ + "/logs/" + c.name + ".log", 1);   // the card's board names itself (pil.md)
            const std::size_t a = last.find_first_not_of(" \n"), b = last.find_last_not_of(" \n");
            if (last.find("the card's board") != std::string::npos) why += ": " + last.substr(a, b + 1 - a);
            return why;
        }
        return "";
    }

    // A live process whose heartbeats show no progress for --stall-s.
    std::string stalled_process() const
    {
        const auto now = std::chrono::steady_clock::now();
        for (const auto &c : kids_) {
            auto it = prog_.progress_at.find(c.name);
            const auto since = it == prog_.progress_at.end() ? wall0_ : it->second;
            if (!c.exited && std::chrono::duration<double>(now - since).count() > o_.stall_s && !prog_.is(c.name, afm::RunState::done))
                return c.name + " made no progress for " + std::to_string(static_cast<int>(o_.stall_s)) + " s (log: " + out_ + "/logs/" +
                       c.name + ".log)" +
                       (hosts_.count == 2 ? "; the run is on two hosts: the link vhost-vafm (" + hosts_.asked +
                                                ") may have lost a message that has no resend (docs/hosts.md)"
                                          : std::string());
        }
        return "";
    }

    void print_progress(bool started)
    {
        double t_sim = 0;
        if (prog_.last.count("sim_afm")) t_sim = prog_.last["sim_afm"].sim_utime * 1e-6;
        int frames = 0;
        if (prog_.last.count("renderer") && prog_.last["renderer"].sim_utime > 0)
            frames = afm::frames_due(scene_, prog_.last["renderer"].sim_utime);
        if (started)
            std::fprintf(stderr, "\rrun: sim %.2f / %.2f s   frames %d / %d   wall %.1f s   ", t_sim, scene_.duration_s, frames,
                         scene_.total_frames(), wall_s());
        else
            std::fprintf(stderr, "\rrun: starting (scan, processes)   wall %.1f s   ", wall_s());
        std::fflush(stderr);
    }

    static nlohmann::json process_json(const Child &c)
    {
        return {{"name", c.name}, {"exit_code", c.exit_code}, {"log", "logs/" + c.name + ".log"}, {"cpus", c.cpus},
                {"cpu_user_s", c.cpu_user_s}, {"cpu_system_s", c.cpu_system_s}, {"max_rss_kb", c.max_rss_kb}};
    }

    // The launcher itself (run.json "launcher"): it records the bus
    // (bus_recorder.hpp), so its share of the machine is part of a run's cost.
    nlohmann::json launcher_json() const
    {
        struct rusage ru {};
        getrusage(RUSAGE_SELF, &ru);
        return {{"rejected", inbox_ ? inbox_->rejected().to_json() : nlohmann::json(nullptr)},
                {"recorded_events", recorded_events_},
                {"tap_dropped", tap_ ? tap_->dropped() : 0},   // datagrams no LCM message (bus_tap.hpp)
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
    int pump(int timeout_ms)
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
    bool record(bool bus_quiet)
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

    nlohmann::json run_json()
    {
        using nlohmann::json;
        std::string log_err;
        RecordedBlocks recorded;
        const auto counts = count_channels(out_ + "/bus.lcmlog", &log_err, &recorded);
        for (const auto &kv : counts) messages_ += kv.second;
        json run;
        run["schema_version"] = kRunSchemaVersion;
        run["provenance"] = provenance();
        run["scene"] = scene_abs_;
        run["scene_hash"] = scene_hash_;
        run["scene_name"] = scene_.name;
        run["seed"] = scene_.seed;
        run["status"] = interrupted_ ? "interrupted" : failure_.empty() ? "ok" : "failed";
        if (!failure_.empty()) run["error"] = failure_;
        const char *ns_mode = std::getenv("AFM_NETNS_MODE");
        run["netns"] = ns_mode ? ns_mode : "unknown";
        run["bus_url"] = bus_url();
        run["time_mode"] = scene_.time_mode;
        const double sim_s = prog_.last.count("sim_afm") ? prog_.last["sim_afm"].sim_utime * 1e-6 : 0.0;
        run["sim_seconds"] = sim_s;
        run["wall_seconds"] = wall_;
        run["sim_seconds_per_wall_second"] = wall_ > 0 ? sim_s / wall_ : 0.0;
        run["samples"] = std::llround(sim_s * scene_.sample_rate_hz);
        int frames = 0;
        for (const auto &e : fs::directory_iterator(out_ + "/frames"))
            if (e.path().extension() == ".png") ++frames;
        run["frames"] = frames;
        run["frames_expected"] = scene_.total_frames();   // fewer when the planner finished early (the renderer's report)
        json procs = json::array();
        std::vector<std::string> names;
        for (const auto &c : kids_) {
            procs.push_back(process_json(c));
            procs.back()["host"] = hosts_.count == 2 ? hosts_.where(c.name) : "one";
            names.push_back(c.name);
        }
        run["processes"] = procs;
        run["hosts"] = hosts_.json(names);
        run["log_bytes"] = fs::exists(out_ + "/bus.lcmlog") ? static_cast<int64_t>(fs::file_size(out_ + "/bus.lcmlog")) : 0;
        run["channels"] = afm::channels_json(counts);
        if (!log_err.empty()) run["log_error"] = log_err;
        run["card"] = card_json();
        run["launcher"] = launcher_json();
        run["placement"] = placement_json();
        merge_reports(&run);
        run["timing"] = timing_json(run);
        if (run.contains("fw") && run["fw"].contains("board")) run["card"]["board"] = run["fw"]["board"];   // where the card ran
        if (run.contains("renderer") && run["renderer"].contains("frames_expected")) run["frames_expected"] = run["renderer"]["frames_expected"];
        run["verdict"] = afm::judge(run, scene_.expect);   // the run's own checks (verdict.hpp)
        // Completeness of the record: distinct analog blocks and poses in the
        // log against the blocks the simulator simulated (a recorder starved
        // of CPU can lose datagrams; a block missing either input cannot be replayed).
        if (run.contains("sim") && run["sim"].contains("blocks")) {
            const int64_t sent = run["sim"]["blocks"].get<int64_t>();
            // a block the simulator sent (a datagram with another seq is not one)
            auto in_run = [&](const std::set<int64_t> &s) {
                return static_cast<int64_t>(std::count_if(s.begin(), s.end(), [&](int64_t q) { return q >= 0 && q < sent; }));
            };
            const int64_t analog_seqs = in_run(recorded.analog), pose_seqs = in_run(recorded.pose);
            const bool complete = analog_seqs == sent && pose_seqs == sent;
            run["log"] = {{"analog_blocks_recorded", analog_seqs},
                          {"pose_blocks_recorded", pose_seqs},
                          {"analog_blocks_simulated", sent},
                          {"complete", complete}};
            if (!complete)
                std::fprintf(stderr,
                             "run: warning: the bus log holds %lld analog blocks and %lld poses of %lld blocks (the recorder was starved of CPU)\n",
                             static_cast<long long>(analog_seqs), static_cast<long long>(pose_seqs), static_cast<long long>(sent));
        }
        json outs = {"bus.lcmlog", "run.json", "scene.yaml", "frames/"};
        for (const char *v : {"video.mp4", "video.avi", "contact_sheet.png", "scan_initial.png", "scan_initial.gsf", "scan_final.gsf",
                              "display_final.gsf", "fidelity.json", "fidelity_diff.png"})
            if (fs::exists(out_ + "/" + v)) outs.push_back(v);
        for (const auto &e : fs::directory_iterator(out_))
            if (e.path().filename().string().rfind("scan_local_", 0) == 0) outs.push_back(e.path().filename().string());
        run["outputs"] = outs;
        return run;
    }

    // What the card ran with, in the firmware's units (fw_card_init on the
    // scene's configuration, as fw_node has it): the displacement constants
    // in use, the chain, the ADC.
    nlohmann::json card_json() const
    {
        const afm::CardSetup setup(scene_);
        fw_card_t card;
        if (fw_card_init(&card, &setup.config(), &setup.storage(), nullptr) != FW_OK) return nullptr;
        const fw_board_config_t &b = setup.config().board;
        return {{"adc_bits", b.adc_bits},
                {"word_bits", setup.config().word_bits == 0 ? 32 : setup.config().word_bits},
                {"normal_gain_pn_per_v", b.normal_gain_pn_per_v},
                {"lateral_gain_pn_per_v", b.lateral_gain_pn_per_v},
                {"deflection_pm_per_v", b.deflection_pm_per_v},
                {"disp_n_pm_per_v", fw_card_disp_n_pm_per_v(&card)},
                {"disp_l_pm_per_v", fw_card_disp_l_pm_per_v(&card)},
                {"scan_angle_mdeg", b.scan_angle_mdeg},
                {"mu_ppm", b.mu_ppm},
                {"adhesion_pn", b.adhesion_pn},
                {"wire_friction_pn_per_um", setup.config().wire_friction_pn_per_um},
                {"wire_mu_ppm", setup.config().wire_mu_ppm},
                {"twist_urad_per_v", static_cast<double>(card.twist_rad_per_v) * 1e6 / static_cast<double>(1 << 30)},
                {"samples_per_block", scene_.samples_per_block()},
                {"full_scale_pn", fw_guard_full_scale_pn(b.normal_gain_pn_per_v)}};
    }

    // The card on its board (--firmware qemu): its instructions per block against a 168 MHz budget.
    static void print_board(const nlohmann::json &run)
    {
        if (!run.contains("card") || !run["card"].is_object() || !run["card"].contains("board")) return;
        const auto &b = run["card"]["board"];
        if (b.value("firmware", "host") != "qemu" || !b.contains("budget")) return;
        const auto &i = b["instructions_per_block"], &g = b["budget"];
        std::printf("run: the card on its board (%s): %.0f instructions a block median, %.0f worst (%.0f, %.0f a sample); "
                    "%.2f %% of a 168 MHz Cortex-M4's block at CPI 1 worst, %.2f %% at CPI 2 (icount counts instructions, not "
                    "cycles); a round trip %.0f us median\n",
                    b["machine"].get<std::string>().c_str(), i["median"].get<double>(), i["worst"].get<double>(),
                    b["instructions_per_sample"]["median"].get<double>(), b["instructions_per_sample"]["worst"].get<double>(),
                    100 * g["fraction_worst_cpi1"].get<double>(), 100 * g["fraction_worst_cpi2"].get<double>(),
                    b["round_trip_us"]["median"].get<double>());
    }

    // What the page's bridge refused (run.json launcher.view_bridge), when it refused anything.
    static void print_view_bridge(const nlohmann::json &b)
    {
        if (!b.is_object() || !b.contains("rejected")) return;
        const int64_t unproven = b["rejected"]["unproven"].value("total", int64_t{0});
        const int64_t foreign = b["rejected"].value("foreign_datagrams", int64_t{0});
        if (unproven + foreign == 0) return;
        std::printf("run: the page's bridge refused %lld messages without the run's proof and %lld from no process of the run that "
                    "publishes their channel (logs/view_bridge.log)\n",
                    static_cast<long long>(unproven), static_cast<long long>(foreign));
    }

    // The planner's account (operator_report.json) and its result in the
    // fresh scan (fidelity.json "placement"), as run.json holds them.
    static void print_plan(const nlohmann::json &run)
    {
        if (run.contains("operator") && run["operator"].contains("haptic")) {
            const auto &h = run["operator"]["haptic"];
            std::printf("run: haptic: gain %.3f N/nN, K_r %.0f N/m against the bound %.0f N/m (%s); the passivity controller acted in %ld "
                        "blocks, %.3g J; %zu contacts felt\n",
                        h.value("gain_N_per_nN", 0.0), h.value("rendered_stiffness_N_per_m", 0.0), h.value("passivity_bound_N_per_m", 0.0),
                        h.value("passive", false) ? "inside" : "OUTSIDE", h.value("controller_blocks", 0L), h.value("controller_energy_J", 0.0),
                        run["operator"].contains("contacts_felt") ? run["operator"]["contacts_felt"].size() : std::size_t{0});
        }
        if (!run.contains("operator") || !run["operator"].contains("plan")) return;
        const auto &p = run["operator"]["plan"];
        const double done_s = p["finished_sim_s"].is_number() ? p["finished_sim_s"].get<double>() : -1;
        char when[128];
        if (done_s >= 0) std::snprintf(when, sizeof when, "done at %.1f simulated s (%.1f wall s)", done_s, p.value("planner_wall_s", 0.0));
        else std::snprintf(when, sizeof when, "NOT done when the run ended (give a longer duration_s)");
        std::printf("run: plan: %d pushes (%d again after a miss), %d local scans, %d fixes; %s\n", p.value("pushes", 0),
                    p.value("repushes", 0), p.value("local_scans", 0), p.value("fixes", 0), when);
        if (!run.contains("fidelity") || !run["fidelity"].contains("placement")) return;
        const auto &pl = run["fidelity"]["placement"];
        if (pl.contains("particles")) {
            const auto &q = pl["particles"];
            std::printf("run: placement (a fresh scan): %d of %d sites hold a particle within %.0f nm (%d empty); worst %.1f nm, RMS %.1f nm\n",
                        q.value("placed", 0), q.value("sites", 0), q.value("tolerance_nm", 0.0), q.value("missing", 0),
                        q.value("worst_nm", 0.0), q.value("rms_nm", 0.0));
        }
        if (pl.contains("rods"))
            for (const auto &r : pl["rods"]) {
                char err[64] = "not found in the scan";
                if (r["error_nm"].is_number()) std::snprintf(err, sizeof err, "ends within %.1f nm", r["error_nm"].get<double>());
                std::printf("run: placement (a fresh scan): rod %d %s (tolerance %.0f nm), %s\n", r.value("id", 0),
                            r.value("placed", false) ? "on its target" : "OFF its target", r.value("tolerance_nm", 0.0), err);
            }
    }

    // Each process's own report, under its name.
    // The run's speed "as a run is made" (docs/design.md, run.json timing):
    // the loop, from the simulator's first block to the card's answer to
    // its last (sim_report.json loop_wall_seconds, the one owner of that
    // figure: scans served and waits for frames and the record included),
    // against the blocks' simulated time; beside it the whole run, the
    // launcher's start to the end of the run (wall_seconds). Null figures
    // when the simulator wrote no report.
    nlohmann::json timing_json(const nlohmann::json &run) const
    {
        nlohmann::json t = {{"whole_seconds", wall_}, {"whole_realtime_factor", run["sim_seconds_per_wall_second"]}};
        const bool have = run.contains("sim") && run["sim"].is_object() && run["sim"].contains("loop_wall_seconds") && run["sim"].contains("blocks");
        const double loop_s = have ? run["sim"]["loop_wall_seconds"].get<double>() : 0.0;
        const int64_t blocks = have ? run["sim"]["blocks"].get<int64_t>() : 0;
        const double loop_sim_s = static_cast<double>(blocks) / scene_.block_hz;
        const bool ok = have && loop_s > 0 && blocks > 0;
        t["loop_seconds"] = ok ? nlohmann::json(loop_s) : nlohmann::json(nullptr);
        t["loop_blocks"] = blocks;
        t["loop_simulated_seconds"] = loop_sim_s;
        t["loop_us_per_block"] = ok ? nlohmann::json(loop_s / static_cast<double>(blocks) * 1e6) : nlohmann::json(nullptr);
        t["loop_realtime_factor"] = ok ? nlohmann::json(loop_sim_s / loop_s) : nlohmann::json(nullptr);
        t["outside_loop_seconds"] = ok ? nlohmann::json(wall_ - loop_s) : nlohmann::json(nullptr);
        // CPU a block in the loop, per process (from the run's start, within
        // the launcher's 5 ms checks, to the simulator's heartbeat for its
        // last block, within a batch of the record: about the loop), with its descendants, and of that "NAME (its children)":
        // QEMU under fw_node, ffmpeg under the renderer; afm_launch is the
        // record and the heartbeats
        nlohmann::json cpu = nullptr;
        if (ok && loop_cpu_taken_ == 2) {
            cpu = nlohmann::json::object();
            // a figure is given only where both readings are whole: a process
            // whose descendants were fewer, or had used less, at the end (one
            // ending between the readings) gets none, rather than a short one
            const auto per_block = [&](double a, double b) { return (b - a) / static_cast<double>(blocks) * 1e6; };
            for (const auto &[name, end] : loop_cpu_[1]) {
                const auto it = loop_cpu_[0].find(name);
                if (it == loop_cpu_[0].end()) continue;
                const LoopCpu &start = it->second;
                if (start.total < 0 || end.total < start.total) continue;
                if (start.children >= 0 && end.children < start.children) continue;
                cpu[name] = per_block(start.total, end.total);
                if (start.children >= 0) cpu[name + " (its children)"] = per_block(start.children, end.children);
            }
        }
        t["loop_cpu_us_per_block"] = cpu;
        return t;
    }

    void merge_reports(nlohmann::json *run) const
    {
        for (const std::string rep : {"sim_report.json", "renderer_report.json", "operator_report.json", "fw_report.json", "fidelity.json"}) {
            std::ifstream f(out_ + "/" + rep);
            if (!f) continue;
            nlohmann::json j = nlohmann::json::parse(f, nullptr, false);
            if (j.is_discarded()) {
                (*run)["report_errors"].push_back(rep + ": not valid JSON");
                continue;
            }
            const std::string key = rep.substr(0, rep.find_first_of("_."));
            if (key == "sim" && j.contains("effects")) (*run)["effects"] = j["effects"];
            (*run)[key] = j;
        }
    }
};

}  // namespace afm::launch

