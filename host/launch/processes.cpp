#include "processes.hpp"

#include <filesystem>

#include "senders.hpp"

namespace afm::launch {

namespace fs = std::filesystem;

std::string exe_dir() { return fs::canonical("/proc/self/exe").parent_path().string(); }

std::string view_bridge_path() { return exe_dir() + "/afm_view_bridge"; }

namespace {

// A process of the run, or the page's bridge: its output to logs/NAME.log,
// the bus's URL, below the launcher's priority, on its CPUs, with the run's
// key. Two hosts: in the run's inner user namespace (the afm namespace's
// owner), so that they read one another's sockets, and its network
// namespace too where NAME runs there; it drops what entering gave
// (AFM_DROP_CAPS); the launcher's ports said in its stead.
Process in_run(const std::string &name, std::vector<std::string> argv, const RunPlaces &p)
{
    Process r;
    r.name = name;
    r.log = p.out + "/logs/" + name + ".log";
    r.env = {"LCM_DEFAULT_URL=" + p.bus_url};
    r.nice = kBusProcessNice;
    r.cpus = p.placement->cpus_for(name);
    r.key = true;
    if (p.hosts->count == 2) {
        r.env.insert(r.env.end(), {p.hosts->bus_link_env(name), std::string(afm::Senders::kParentPortsEnv) + "=" + p.parent_ports});
        argv.insert(argv.begin(), p.hosts->drop_caps);
        r.entry = {p.hosts->afm_ns_pid, p.hosts->on_afm(name)};
    }
    r.argv = std::move(argv);
    return r;
}

std::vector<std::string> sim_argv(const Options &o, const RunPlaces &p)
{
    std::vector<std::string> a = {p.bin + "/../sim_afm/sim_afm", "--scene", p.scene_run, "--out", p.out, "--inject-drop", std::to_string(o.drop_p)};
    if (p.log_window > 0) a.insert(a.end(), {"--follow-log", p.out + "/bus.lcmlog", "--log-window", std::to_string(p.log_window)});
    if (!o.renderer) a.push_back("--no-renderer");
    if (p.hosts->resend_ms() > 0) a.insert(a.end(), {"--resend-ms", std::to_string(p.hosts->resend_ms())});
    return a;
}

std::vector<std::string> fw_argv(const Options &o, const RunPlaces &p)
{
    return {p.bin + "/fw_node", "--scene", p.scene_run, "--out", p.out, "--crash-at-block", std::to_string(o.crash_block), "--firmware", o.firmware};
}

std::vector<std::string> renderer_argv(const Options &o, const RunPlaces &p)
{
    std::vector<std::string> a = {p.bin + "/renderer", "--scene", p.scene_run, "--out", p.out};
    if (o.view) a.push_back("--view-frames");
    return a;
}

// lcm-spy (--spy): a window on the bus, at the launcher's priority, without
// the key; started through run/spy.sh, which picks a Java runtime with AWT.
Process spy(const RunPlaces &p)
{
    Process r;
    r.name = "lcm-spy";
    r.role = Process::Role::observer;
    r.argv = {p.spy_launcher, "--lcm-url=" + p.bus_url};
    r.log = p.out + "/logs/lcm-spy.log";
    r.env = {"LCM_DEFAULT_URL=" + p.bus_url, "CLASSPATH=" + p.types_jar, "AFM_LCM_BIN=" + p.lcm_bin};
    r.cpus = p.placement->cpus_for("lcm-spy");
    return r;
}

}  // namespace

std::vector<Process> run_processes(const Options &o, const RunPlaces &p)
{
    std::vector<Process> t;
    if (o.spy) t.push_back(spy(p));
    if (o.view_fd >= 0) {
        t.push_back(in_run("view_bridge", {view_bridge_path(), "--fd", std::to_string(kPassedFd), "--report", p.out + "/" + kViewBridgeReport}, p));
        t.back().role = Process::Role::observer;
        t.back().view_fd = true;
    }
    std::vector<std::string> sim = sim_argv(o, p), fw = fw_argv(o, p), renderer = renderer_argv(o, p);
    if (p.placement->on()) {
        // the threads that publish aside (bus/aside.hpp) and the frame
        // writer (frame_writer.hpp) on any CPU of the run: the kernel puts
        // them where there is room (the observers' CPU is the run's busiest)
        const std::string all = afm::cpu_list(p.placement->all());
        for (auto *a : {&sim, &fw}) a->insert(a->end(), {"--aside-cpus", all});
        renderer.insert(renderer.end(), {"--writer-cpus", all});
    }
    t.push_back(in_run("sim_afm", sim, p));
    t.push_back(in_run("fw_node", fw, p));
    t.push_back(in_run("operator", {p.bin + "/operator", "--scene", p.scene_run, "--out", p.out}, p));
    if (o.renderer) t.push_back(in_run("renderer", renderer, p));
    return t;
}

std::vector<std::string> run_process_names(const Options &o)
{
    const Hosts one;
    const Placement none;
    RunPlaces p;
    p.hosts = &one;
    p.placement = &none;
    std::vector<std::string> names;
    for (const auto &r : run_processes(o, p))
        if (r.role == Process::Role::run) names.push_back(r.name);
    return names;
}

const Process *find_process(const std::vector<Process> &table, const std::string &name)
{
    for (const auto &r : table)
        if (r.name == name) return &r;
    return nullptr;
}

}  // namespace afm::launch
