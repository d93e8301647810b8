#include "supervisor.hpp"

#include <time.h>

#include <algorithm>
#include <thread>

namespace afm::launch {

volatile sig_atomic_t g_signal = 0;

namespace {

void on_stop_signal(int sig) { g_signal = sig; }

void signal_child(Child &c, int sig)
{
    if (!c.exited && c.pid > 0) kill(c.pid, sig);
}

}  // namespace

void catch_stop_signals()
{
    signal(SIGPIPE, SIG_IGN);
    struct sigaction sa {};
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
}

void Supervisor::start(const Process &p, int key_fd, int pass_fd)
{
    Child c{p.name};
    c.pid = spawn(p.argv, p.log, p.env, p.nice, p.cpus, p.entry, p.key ? key_fd : -1, p.view_fd ? pass_fd : -1);
    (p.role == Process::Role::run ? run_ : observers_).push_back(c);
}

std::vector<std::string> Supervisor::names() const
{
    std::vector<std::string> n;
    for (const auto &c : run_) n.push_back(c.name);
    return n;
}

Child *Supervisor::observer(const std::string &name)
{
    for (auto &c : observers_)
        if (c.name == name) return &c;
    return nullptr;
}

const Child *Supervisor::observer(const std::string &name) const { return const_cast<Supervisor *>(this)->observer(name); }

void Supervisor::reap()
{
    for (auto &c : run_) c.reap();
    if (Child *spy = observer("lcm-spy")) spy->reap();
}

bool Supervisor::all_exited() const
{
    return std::all_of(run_.begin(), run_.end(), [](const Child &c) { return c.exited; });
}

std::string Supervisor::dead(const Progress &prog, const std::string &out) const
{
    // The simulator ends the run: once it has said "done", or has itself
    // exited cleanly, a clean exit of any process is the run's end.
    const bool sim_ended = prog.is("sim_afm", RunState::done) ||
                           std::any_of(run_.begin(), run_.end(),
                                       [](const Child &c) { return c.name == "sim_afm" && c.exited && c.exit_code == 0; });
    for (const auto &c : run_) {
        if (!c.exited || (c.exit_code == 0 && (sim_ended || c.name == "sim_afm"))) continue;
        // A clean exit: the process heard the simulator's "done", which
        // the launcher may not have dispatched yet; given a moment.
        if (c.exit_code == 0 && std::chrono::steady_clock::now() - c.exited_at < std::chrono::milliseconds(kCleanExitGraceMs)) continue;
        std::string why = c.name + " died with exit code " + std::to_string(c.exit_code) + " (log: " + out + "/logs/" + c.name + ".log)";
        const std::string last = slurp_tail(out + "/logs/" + c.name + ".log", 1);   // the card's board names itself (pil.md)
        const std::size_t a = last.find_first_not_of(" \n"), b = last.find_last_not_of(" \n");
        if (last.find("the card's board") != std::string::npos) why += ": " + last.substr(a, b + 1 - a);
        return why;
    }
    return "";
}

std::vector<std::string> Supervisor::live() const
{
    std::vector<std::string> l;
    for (const auto &c : run_)
        if (!c.exited) l.push_back(c.name);
    return l;
}

void Supervisor::kill_named(const std::string &name)
{
    for (auto &c : run_)
        if (c.name == name && !c.exited) kill(c.pid, SIGKILL);
}

void Supervisor::read_cpus()
{
    for (auto &c : run_) c.cpus = afm::cpu_list(afm::cpus_of(c.pid));
    if (Child *b = observer("view_bridge")) b->cpus = afm::cpu_list(afm::cpus_of(b->pid));
}

void Supervisor::signal_run(int sig)
{
    for (auto &c : run_) signal_child(c, sig);
}

void Supervisor::kill_run()
{
    for (auto &c : run_) {
        signal_child(c, SIGKILL);
        c.reap(true);
    }
}

// SIGTERM to afm_view_bridge: it passes on what its socket still holds,
// says in its log what it refused, writes its report and ends.
void Supervisor::stop_view_bridge()
{
    Child *b = observer("view_bridge");
    if (!b || b->pid <= 0) return;
    b->reap();
    if (!b->exited) kill(b->pid, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(kViewBridgeStopMs);
    while (!b->exited && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        b->reap();
    }
    if (!b->exited) kill(b->pid, SIGKILL);
    b->reap(true);
}

void Supervisor::close_spy(bool failed)
{
    Child *spy = observer("lcm-spy");
    if (!spy || spy->exited) return;
    if (!failed) std::fprintf(stderr, "run: the run is over; close lcm-spy to finish\n");
    else signal_child(*spy, SIGTERM);
    while (!spy->exited && !g_signal) {
        spy->reap();
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (!spy->exited) signal_child(*spy, SIGTERM);
    spy->reap(true);
}

CpuReading Supervisor::cpu_reading() const
{
    CpuReading m;
    for (const auto &c : run_) {
        double below = 0;
        LoopCpu &x = m[c.name];
        x.total = c.exited ? c.cpu_user_s + c.cpu_system_s : tree_cpu_seconds(c.pid, &below);
        if (!c.exited && below > 0) x.children = below;
    }
    timespec ts{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    m["afm_launch"].total = ts.tv_sec + ts.tv_nsec * 1e-9;
    return m;
}

}  // namespace afm::launch
