// afm_launch: runs one scene. Validates the scene before starting anything,
// checks that it sits in a private network namespace whose loopback carries
// the multicast route (./afm run puts it there), records the whole bus with
// lcm-logger, starts the four processes, prints progress, stops everything
// at the end (or when one dies), and writes DIR/run.json.
#include <lcm/lcm-cpp.hpp>
#include <lcm/lcm.h>

#include <fcntl.h>
#include <signal.h>
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
#include "lcmlog.hpp"
#include "bus.hpp"
#include <nlohmann/json.hpp>
#include "card_setup.hpp"
#include "scene.hpp"

namespace fs = std::filesystem;

namespace {

const char *kUsage =
    "usage: afm_launch --scene FILE --out DIR [options]\n"
    "  Runs one scene through sim_afm, fw_node, operator and renderer on a private\n"
    "  LCM bus, recording it with lcm-logger. ./afm run calls it inside a fresh\n"
    "  network namespace; run directly it refuses unless loopback carries the\n"
    "  multicast route.\n"
    "options:\n"
    "  --check            validate the scene and exit (0: valid, 2: not)\n"
    "  --spy              also start lcm-spy on the run's bus (needs a display); the run\n"
    "                     ends when lcm-spy is closed (time_mode: realtime to watch at pace)\n"
    "  --inject-drop P    sim_afm drops each analog block's first send with probability P\n"
    "  --kill AFTER_S:NAME  failure injection: SIGKILL process NAME AFTER_S wall seconds into the run\n"
    "  --inject-crash fw_node:N  failure injection: fw_node exits (code 70) on analog block N\n"
    "  --stall-s S        abort if the run makes no progress for S wall seconds (default 60)\n"
    "  --quiet            no progress line\n";

struct Child {
    std::string name;
    pid_t pid = -1;
    int exit_code = -1;       // exit status, or 128 + signal
    bool exited = false;
};

int decode_status(int st) { return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st); }

// The bus processes run at a lower priority than lcm-logger, so that on a
// busy machine the logger keeps up (it drops messages once 30 wait in its
// subscription queue) and the run slows down instead.
constexpr int kBusProcessNice = 10;

pid_t spawn(const std::vector<std::string> &argv, const std::string &log_path, const std::vector<std::string> &env_add = {},
            int nice_level = 0)
{
    pid_t pid = fork();
    if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
    if (pid == 0) {
        setpgid(0, 0);
        if (nice_level) setpriority(PRIO_PROCESS, 0, nice_level);
        int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
            close(fd);
        }
        int devnull = open("/dev/null", O_RDONLY);
        if (devnull >= 0) dup2(devnull, 0);
        for (const auto &e : env_add) putenv(const_cast<char *>(e.c_str()));
        std::vector<char *> a;
        for (const auto &s : argv) a.push_back(const_cast<char *>(s.c_str()));
        a.push_back(nullptr);
        execv(a[0], a.data());
        std::fprintf(stderr, "afm_launch: cannot execute %s: %s\n", a[0], std::strerror(errno));
        _exit(127);
    }
    return pid;
}

std::string exe_dir()
{
    return fs::canonical("/proc/self/exe").parent_path().string();
}

// Message counts per channel in an LCM log, and the number of distinct
// analog blocks in it (their seq, decoded with the generated type).
std::map<std::string, int64_t> count_channels(const std::string &path, std::string *err, int64_t *analog_seqs)
{
    std::map<std::string, int64_t> counts;
    std::set<int64_t> seqs;
    try {
        afm::LogReader log(path);
        afm::LogEvent ev;
        while (log.read(&ev)) {
            ++counts[ev.channel];
            afm::analog_block_t b;
            if (ev.channel == AFM_CH_AFM_ANALOG && b.decode(ev.data.data(), 0, static_cast<int>(ev.data.size())) >= 0)
                seqs.insert(b.seq);
        }
    } catch (const afm::LogError &e) {
        *err = e.what();
    }
    *analog_seqs = static_cast<int64_t>(seqs.size());
    return counts;
}

struct Progress {
    std::map<std::string, afm::heartbeat_t> last;
    std::map<std::string, std::chrono::steady_clock::time_point> progress_at;
    void on_hb(const lcm::ReceiveBuffer *, const std::string &, const afm::heartbeat_t *m)
    {
        auto it = last.find(m->name);
        if (it == last.end() || it->second.seq != m->seq || it->second.state != m->state)
            progress_at[m->name] = std::chrono::steady_clock::now();
        last[m->name] = *m;
    }
    bool is(const std::string &name, const std::string &state) const
    {
        auto it = last.find(name);
        return it != last.end() && it->second.state == state;
    }
};

std::string slurp_tail(const std::string &path, std::size_t max_lines)
{
    std::ifstream f(path);
    std::vector<std::string> lines;
    std::string l;
    while (std::getline(f, l)) lines.push_back(l);
    std::string out;
    for (std::size_t i = lines.size() > max_lines ? lines.size() - max_lines : 0; i < lines.size(); ++i) out += "    " + lines[i] + "\n";
    return out;
}

}  // namespace

int main(int argc, char **argv)
{
    std::string scene_path, out_dir;
    bool spy = false, quiet = false;
    double drop_p = 0, stall_s = 60, kill_after = -1;
    std::string kill_name;
    bool check_only = false;
    long long crash_block = -1;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        auto val = [&]() -> std::string {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "afm_launch: %s needs a value\n", a.c_str());
                std::exit(2);
            }
            return argv[++i];
        };
        if (a == "--scene") scene_path = val();
        else if (a == "--out") out_dir = val();
        else if (a == "--spy") spy = true;
        else if (a == "--check") check_only = true;
        else if (a == "--quiet") quiet = true;
        else if (a == "--inject-drop") drop_p = std::atof(val().c_str());
        else if (a == "--stall-s") stall_s = std::atof(val().c_str());
        else if (a == "--kill") {
            const std::string v = val();
            const auto colon = v.find(':');
            if (colon == std::string::npos) { std::fprintf(stderr, "afm_launch: --kill wants AFTER_S:NAME, got '%s'\n", v.c_str()); return 2; }
            kill_after = std::atof(v.substr(0, colon).c_str());
            kill_name = v.substr(colon + 1);
        }
        else if (a == "--inject-crash") {
            const std::string v = val();
            if (v.rfind("fw_node:", 0) != 0) { std::fprintf(stderr, "afm_launch: --inject-crash supports fw_node:N, got '%s'\n", v.c_str()); return 2; }
            crash_block = std::atoll(v.substr(8).c_str());
        }
        else if (a == "-h" || a == "--help") { std::fputs(kUsage, stdout); return 0; }
        else { std::fprintf(stderr, "afm_launch: unknown argument '%s'\n%s", a.c_str(), kUsage); return 2; }
    }
    if (scene_path.empty() || (out_dir.empty() && !check_only)) { std::fputs(kUsage, stderr); return 2; }
    if (!(drop_p >= 0 && drop_p < 1)) { std::fprintf(stderr, "afm_launch: --inject-drop must be in [0, 1), got %g\n", drop_p); return 2; }

    // 1. The scene, before anything starts.
    afm::Scene scene;
    try {
        scene = afm::load_scene(scene_path);
    } catch (const afm::SceneError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
    }
    if (const std::string why_fw = afm::card_refusal(scene); !why_fw.empty()) {
        std::fprintf(stderr, "%s: %s\n", scene_path.c_str(), why_fw.c_str());
        return 2;
    }
    if (check_only) return 0;
    // 2. The bus must stay on this namespace's loopback.
    std::string why;
    if (!afm::multicast_routed_on_loopback(&why)) {
        std::fprintf(stderr, "afm_launch: %s\n", why.c_str());
        return 2;
    }
    // 3. The run folder: a fresh one, or an earlier run's (its outputs replaced).
    try {
        if (fs::exists(out_dir) && !fs::is_empty(out_dir) && !fs::exists(fs::path(out_dir) / "run.json") &&
            !fs::exists(fs::path(out_dir) / "bus.lcmlog")) {
            std::fprintf(stderr, "afm_launch: output folder %s exists and holds something that is not a run; choose another --out\n", out_dir.c_str());
            return 2;
        }
        for (const char *old : {"frames", "logs", "bus.lcmlog", "run.json", "scene.yaml", "video.mp4", "video.avi", "sim_report.json",
                                "renderer_report.json", "operator_report.json", "scan_initial.png", "contact_sheet.png",
                                "scan_initial.gsf", "scan_final.gsf", "display_final.gsf", "fidelity.json", "fidelity_diff.png"})
            fs::remove_all(fs::path(out_dir) / old);
        fs::create_directories(fs::path(out_dir) / "logs");
        fs::create_directories(fs::path(out_dir) / "frames");
        for (const auto &e : fs::directory_iterator(out_dir))
            if (e.path().filename().string().rfind("scan_local_", 0) == 0) fs::remove(e.path());
    } catch (const fs::filesystem_error &e) {
        std::fprintf(stderr, "afm_launch: cannot prepare output folder %s: %s\n", out_dir.c_str(), e.what());
        return 2;
    }
    const std::string out = fs::canonical(out_dir).string();
    const std::string scene_abs = fs::canonical(scene_path).string();
    // The run keeps the scene it runs, and its processes read that copy:
    // what the run ran stays known (replay reads it) while the original may
    // change.
    const std::string scene_run = out + "/scene.yaml";
    try {
        fs::copy_file(scene_abs, scene_run, fs::copy_options::overwrite_existing);
    } catch (const fs::filesystem_error &e) {
        std::fprintf(stderr, "afm_launch: cannot copy the scene into %s: %s\n", out.c_str(), e.what());
        return 2;
    }
    const std::string bin = exe_dir();
    const std::string url_env = std::string("LCM_DEFAULT_URL=") + afm::kBusUrl;
    signal(SIGPIPE, SIG_IGN);

    std::unique_ptr<lcm::LCM> lc;
    try {
        setenv("LCM_DEFAULT_URL", afm::kBusUrl, 1);
        lc = afm::open_bus();
    } catch (const std::exception &e) {
        std::fprintf(stderr, "afm_launch: %s\n", e.what());
        return 2;
    }
    Progress prog;
    lc->subscribe(AFM_CH_AFM_HEARTBEAT, &Progress::on_hb, &prog)->setQueueCapacity(afm::kQueueCapacity);
    afm::Heartbeat hb(*lc, "launcher");

    const auto wall0 = std::chrono::steady_clock::now();
    auto wall_s = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count(); };

    // 4. Logger first; the processes start once it records (its file grows
    //    with our own heartbeats), so the log holds the whole run.
    Child logger{"lcm-logger"};
    logger.pid = spawn({std::string(AFM_LCM_BIN) + "/lcm-logger", "--quiet", "-f", "--flush-interval=1", "-l", afm::kBusUrl, out + "/bus.lcmlog"},
                       out + "/logs/lcm-logger.log");
    for (;;) {
        hb.send("starting", 0, 0, "waiting for lcm-logger");
        lc->handleTimeout(50);
        std::error_code ec;
        if (fs::exists(out + "/bus.lcmlog", ec) && fs::file_size(out + "/bus.lcmlog", ec) > 0) break;
        int st;
        if (waitpid(logger.pid, &st, WNOHANG) == logger.pid) {
            std::fprintf(stderr, "afm_launch: lcm-logger exited with code %d before recording (log: %s/logs/lcm-logger.log)\n",
                         decode_status(st), out.c_str());
            return 1;
        }
        if (wall_s() > 10) {
            std::fprintf(stderr, "afm_launch: lcm-logger recorded nothing in 10 s (log: %s/logs/lcm-logger.log)\n", out.c_str());
            kill(logger.pid, SIGKILL);
            return 1;
        }
    }
    std::vector<Child> kids = {{"sim_afm"}, {"fw_node"}, {"operator"}, {"renderer"}};
    std::vector<std::vector<std::string>> cmds = {
        {bin + "/../sim_afm/sim_afm", "--scene", scene_run, "--out", out, "--inject-drop", std::to_string(drop_p),
         "--follow-log", out + "/bus.lcmlog"},
        {bin + "/fw_node", "--scene", scene_run, "--crash-at-block", std::to_string(crash_block)},
        {bin + "/operator", "--scene", scene_run, "--out", out},
        {bin + "/renderer", "--scene", scene_run, "--out", out},
    };
    Child spy_child{"lcm-spy"};
    for (std::size_t i = 0; i < kids.size(); ++i)
        kids[i].pid = spawn(cmds[i], out + "/logs/" + kids[i].name + ".log", {url_env}, kBusProcessNice);
    if (spy) {
        spy_child.pid = spawn({std::string(AFM_LCM_BIN) + "/lcm-spy", "--lcm-url=" + std::string(afm::kBusUrl)}, out + "/logs/lcm-spy.log",
                              {url_env, std::string("CLASSPATH=") + AFM_TYPES_JAR});
    }

    // 5. Supervise.
    std::string failure;
    bool started = false, finished = false;
    auto last_print = std::chrono::steady_clock::now() - std::chrono::seconds(10);
    const int frames_total = scene.total_frames();
    const double sim_total = scene.duration_s;
    auto reap = [&](Child &c) {
        if (c.exited || c.pid <= 0) return;
        int st;
        if (waitpid(c.pid, &st, WNOHANG) == c.pid) {
            c.exited = true;
            c.exit_code = decode_status(st);
        }
    };
    while (true) {
        lc->handleTimeout(20);
        for (auto &c : kids) reap(c);
        reap(logger);
        reap(spy_child);
        if (logger.exited) { failure = "lcm-logger died with exit code " + std::to_string(logger.exit_code); break; }
        for (auto &c : kids) {
            if (c.exited && (c.exit_code != 0 || !prog.is("sim_afm", "done"))) {
                if (c.name == "sim_afm" && c.exit_code == 0) continue;
                failure = c.name + " died with exit code " + std::to_string(c.exit_code) + " (log: " + out + "/logs/" + c.name + ".log)";
                break;
            }
        }
        if (!failure.empty()) break;
        if (std::all_of(kids.begin(), kids.end(), [](const Child &c) { return c.exited; })) { finished = true; break; }
        if (kill_after >= 0 && wall_s() >= kill_after) {
            for (auto &c : kids) if (c.name == kill_name && !c.exited) kill(c.pid, SIGKILL);
            kill_after = -1;
        }
        // Start the run once every process is ready and the logger records (its file grows).
        if (!started) {
            const bool all_ready = std::all_of(kids.begin(), kids.end(), [&](const Child &c) { return prog.is(c.name, "ready"); });
            if (all_ready) {
                started = true;
                for (auto &kv : prog.progress_at) kv.second = std::chrono::steady_clock::now();
            }
        }
        if (started && !prog.is("sim_afm", "done")) hb.maybe_send("running", 0, 0, 200000);
        // Stall watchdog.
        const auto now = std::chrono::steady_clock::now();
        for (const auto &c : kids) {
            auto it = prog.progress_at.find(c.name);
            const auto since = it == prog.progress_at.end() ? wall0 : it->second;
            if (!c.exited && std::chrono::duration<double>(now - since).count() > stall_s && !prog.is(c.name, "done")) {
                failure = c.name + " made no progress for " + std::to_string(static_cast<int>(stall_s)) + " s (log: " + out + "/logs/" + c.name + ".log)";
            }
        }
        if (!failure.empty()) break;
        if (!quiet && now - last_print >= std::chrono::seconds(1)) {
            last_print = now;
            double t_sim = 0;
            if (prog.last.count("sim_afm")) t_sim = prog.last["sim_afm"].sim_utime * 1e-6;
            int frames = 0;
            if (prog.last.count("renderer") && prog.last["renderer"].sim_utime > 0)
                frames = afm::frames_due(scene, prog.last["renderer"].sim_utime);
            if (started)
                std::fprintf(stderr, "\rrun: sim %.2f / %.2f s   frames %d / %d   wall %.1f s   ", t_sim, sim_total, frames, frames_total, wall_s());
            else
                std::fprintf(stderr, "\rrun: starting (scan, processes)   wall %.1f s   ", wall_s());
            std::fflush(stderr);
        }
    }
    if (!quiet) std::fprintf(stderr, "\n");

    // 6. Stop: on failure, tell and then make everyone stop; stop the logger last.
    auto stop = [&](Child &c, int sig) {
        if (!c.exited && c.pid > 0) kill(c.pid, sig);
    };
    if (!failure.empty()) {
        for (int i = 0; i < 3; ++i) { hb.send("stop", 0, 0, failure); lc->handleTimeout(20); }
        for (auto &c : kids) stop(c, SIGTERM);
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (std::chrono::steady_clock::now() < deadline &&
           !std::all_of(kids.begin(), kids.end(), [](const Child &c) { return c.exited; })) {
        for (auto &c : kids) reap(c);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    for (auto &c : kids) {
        if (!c.exited) {
            stop(c, SIGKILL);
            int st;
            waitpid(c.pid, &st, 0);
            c.exited = true;
            c.exit_code = decode_status(st);
        }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(150));   // let the logger drain
    stop(logger, SIGINT);
    if (!logger.exited) { int st; waitpid(logger.pid, &st, 0); logger.exited = true; logger.exit_code = decode_status(st); }
    // lcm-spy stays open for the person watching (the bus is quiet now); the
    // run ends when they close it. On failure it is closed with the rest.
    if (spy && !spy_child.exited) {
        if (failure.empty()) std::fprintf(stderr, "run: the run is over; close lcm-spy to finish\n");
        else stop(spy_child, SIGTERM);
        int st;
        waitpid(spy_child.pid, &st, 0);
    }
    const double wall = wall_s();

    // 7. run.json
    std::string log_err;
    int64_t analog_seqs = 0;
    const auto counts = count_channels(out + "/bus.lcmlog", &log_err, &analog_seqs);
    int64_t messages = 0;
    for (const auto &kv : counts) messages += kv.second;
    using nlohmann::json;
    json run;
    run["scene"] = scene_abs;
    run["scene_name"] = scene.name;
    run["seed"] = scene.seed;
    run["status"] = failure.empty() ? "ok" : "failed";
    if (!failure.empty()) run["error"] = failure;
    const char *ns_mode = std::getenv("AFM_NETNS_MODE");
    run["netns"] = ns_mode ? ns_mode : "unknown";
    run["bus_url"] = afm::kBusUrl;
    run["time_mode"] = scene.time_mode;
    double sim_s = 0;
    if (prog.last.count("sim_afm")) sim_s = prog.last["sim_afm"].sim_utime * 1e-6;
    run["sim_seconds"] = sim_s;
    run["wall_seconds"] = wall;
    run["sim_seconds_per_wall_second"] = wall > 0 ? sim_s / wall : 0.0;
    run["samples"] = std::llround(sim_s * scene.sample_rate_hz);
    int frames = 0;
    for (const auto &e : fs::directory_iterator(out + "/frames")) if (e.path().extension() == ".png") ++frames;
    run["frames"] = frames;
    run["frames_expected"] = frames_total;
    json procs = json::array();
    for (const auto &c : kids) procs.push_back({{"name", c.name}, {"exit_code", c.exit_code}, {"log", "logs/" + c.name + ".log"}});
    procs.push_back({{"name", "lcm-logger"}, {"exit_code", logger.exit_code}, {"log", "logs/lcm-logger.log"}});
    run["processes"] = procs;
    run["channels"] = json::object();
    for (const auto &kv : counts) run["channels"][kv.first] = kv.second;
    if (!log_err.empty()) run["log_error"] = log_err;
    for (const std::string rep : {"sim_report.json", "renderer_report.json", "operator_report.json", "fidelity.json"}) {
        std::ifstream f(out + "/" + rep);
        if (!f) continue;
        json j = json::parse(f, nullptr, false);
        if (j.is_discarded()) { run["report_errors"].push_back(rep + ": not valid JSON"); continue; }
        const std::string key = rep.substr(0, rep.find_first_of("_."));
        if (key == "sim" && j.contains("effects")) run["effects"] = j["effects"];
        run[key] = j;
    }
    // Completeness of the record: distinct analog blocks in the log against
    // those the simulator simulated (lcm-logger drops when starved of CPU).
    if (run.contains("sim") && run["sim"].contains("blocks")) {
        const int64_t sent = run["sim"]["blocks"].get<int64_t>();
        run["log"] = {{"analog_blocks_recorded", analog_seqs}, {"analog_blocks_simulated", sent}, {"complete", analog_seqs == sent}};
        if (analog_seqs != sent)
            std::fprintf(stderr, "run: warning: the bus log holds %lld of %lld analog blocks (lcm-logger was starved of CPU)\n",
                         static_cast<long long>(analog_seqs), static_cast<long long>(sent));
    }
    json outs = {"bus.lcmlog", "run.json", "scene.yaml", "frames/"};
    for (const char *v : {"video.mp4", "video.avi", "contact_sheet.png", "scan_initial.png", "scan_initial.gsf", "scan_final.gsf",
                          "display_final.gsf", "fidelity.json", "fidelity_diff.png"})
        if (fs::exists(out + "/" + v)) outs.push_back(v);
    for (const auto &e : fs::directory_iterator(out))
        if (e.path().filename().string().rfind("scan_local_", 0) == 0) outs.push_back(e.path().filename().string());
    run["outputs"] = outs;
    {
        std::ofstream f(out + "/run.json");
        f << run.dump(2) << "\n";
        if (!f) { std::fprintf(stderr, "afm_launch: cannot write %s/run.json\n", out.c_str()); return 1; }
    }

    if (!failure.empty()) {
        std::fprintf(stderr, "run: FAILED: %s\n", failure.c_str());
        for (const auto &c : kids) {
            if (c.exit_code != 0) {
                std::fprintf(stderr, "  %s exit code %d; last lines of its log:\n%s", c.name.c_str(), c.exit_code,
                             slurp_tail(out + "/logs/" + c.name + ".log", 5).c_str());
            }
        }
        std::fprintf(stderr, "run: the bus log and run.json are kept in %s\n", out.c_str());
        return 1;
    }
    if (!finished) return 1;
    std::printf("run: ok: %.2f simulated s in %.2f wall s (%.2f sim s per wall s), %d frames, %lld bus messages\n", sim_s, wall,
                wall > 0 ? sim_s / wall : 0.0, frames,
                static_cast<long long>(messages));
    if (run.contains("fidelity")) {
        const json &fj = run["fidelity"];
        std::printf("run: fidelity (display vs a fresh scan at frame %d): max object position error %.2f nm, RMS height difference %.2f nm (%s)\n",
                    fj.value("frame", 0), fj.value("max_position_error_nm", -1.0), fj.value("rms_height_error_nm", -1.0),
                    fj.value("pass", false) ? "within target" : "OUTSIDE the 5 nm target");
    }
    std::printf("run: output in %s\n", out.c_str());
    return 0;
}
