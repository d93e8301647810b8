// The run's processes as one table: each row a process the launcher
// starts, with its name, its program and argv (from the options and the
// run's folder and scene), its log, its environment, its priority, its
// CPUs, the namespaces it enters (two hosts) and what it inherits (the
// run's bus key, the page's pipe). supervisor.hpp starts them in the
// table's order: lcm-spy (--spy) and afm_view_bridge (--view-fd) first,
// observers that must hear the run from its first message, then the run's
// own processes, sim_afm, fw_node, operator and renderer (not with
// --no-renderer), whose heartbeats the launcher follows.
#pragma once

#include <string>
#include <vector>

#include "children.hpp"
#include "hosts.hpp"
#include "options.hpp"
#include "placement.hpp"

namespace afm::launch {

// The bus processes run at a lower priority than the launcher, which
// records the bus, so that on a busy machine the record keeps up and the run
// slows down instead.
constexpr int kBusProcessNice = 10;

// The folder of the launcher's program, where the run's programs are built beside it.
std::string exe_dir();
// afm_view_bridge (host/view), built beside the launcher.
std::string view_bridge_path();
// afm_view_bridge's report in the run's folder (run.json launcher.view_bridge).
inline constexpr const char *kViewBridgeReport = "view_bridge_report.json";

struct Process {
    enum class Role {
        run,        // one of the run's processes: supervised, its heartbeats followed, in run.json processes
        observer,   // lcm-spy, afm_view_bridge: started before the run, stopped after it
    };
    std::string name;               // logs/NAME.log; run.json's name
    Role role = Role::run;
    std::vector<std::string> argv;  // argv[0]: the program's path
    std::string log;                // its output, a path
    std::vector<std::string> env;   // added to its environment
    int nice = 0;
    std::vector<int> cpus;          // empty: where the kernel puts it
    Entry entry;                    // two hosts: the namespaces it enters (children.hpp)
    bool key = false;               // inherits the run's bus key (bus_key.hpp)
    bool view_fd = false;           // inherits the page's pipe at kPassedFd
};

// What the table is made from besides the options.
struct RunPlaces {
    std::string bin;             // the run's programs' folder (exe_dir())
    std::string out;             // the run's folder, absolute
    std::string scene_run;       // the run's copy of the scene
    std::string bus_url;         // the run's bus
    long long log_window = 0;    // the simulator's window on the record, blocks (0: none)
    const Hosts *hosts = nullptr;
    const Placement *placement = nullptr;
    std::string parent_ports;    // two hosts: the launcher's own UDP ports (Senders::own_ports())
    std::string lcm_bin, types_jar;   // lcm-spy's folder and the types' jar for its CLASSPATH
    std::string spy_launcher;         // run/spy.sh: starts lcm-spy with a Java runtime that has AWT
};

std::vector<Process> run_processes(const Options &o, const RunPlaces &p);

// The names of the run's own processes (Role::run) for these options, in the table's order.
std::vector<std::string> run_process_names(const Options &o);

// The row named `name`, or nullptr.
const Process *find_process(const std::vector<Process> &table, const std::string &name);

}  // namespace afm::launch
