// The supervisor: starts the rows of the process table (processes.hpp)
// through spawn (children.hpp), reaps them, finds one that died before the
// run was done or that stalled (progress.hpp), kills one on --kill, stops
// them (SIGTERM, SIGKILL after a grace), stops the page's bridge, waits for
// lcm-spy to be closed, and takes the processes' CPU readings. It also owns
// the launcher's stop signals: SIGINT or SIGTERM to the launcher stops the
// run as on a failure (every child stopped, the record closed, run.json
// written) with status "interrupted", and the launcher exits with 128 + the
// signal.
#pragma once

#include <signal.h>

#include <chrono>
#include <string>
#include <vector>

#include "children.hpp"
#include "processes.hpp"
#include "progress.hpp"
#include "run_record.hpp"

namespace afm::launch {

// The signal that asked the launcher to stop (0: none).
extern volatile sig_atomic_t g_signal;
// SIGINT and SIGTERM set g_signal; SIGPIPE is ignored.
void catch_stop_signals();

class Supervisor {
public:
    // SIGTERM to afm_view_bridge, SIGKILL after this long (a pipe whose reader stopped reading).
    static constexpr int kViewBridgeStopMs = 2000;
    // A run's process that exits 0 before the launcher has read the
    // simulator's "done" is given this long for that message to be read
    // (under load the launcher's reading lags: the clean clone of 46b2590,
    // two paper runs beside another e2e file on two cores, called fw_node
    // dead at 500 ms after a whole run); a process that truly ends early is
    // named after it.
    static constexpr int kCleanExitGraceMs = 5000;

    // Starts one row: a run's process, or an observer (lcm-spy, the page's
    // bridge), with the run's key (key_fd) and the page's pipe (pass_fd) where the row says.
    void start(const Process &p, int key_fd, int pass_fd);

    std::vector<Child> &run() { return run_; }
    const std::vector<Child> &run() const { return run_; }
    std::vector<std::string> names() const;
    // An observer by name (nullptr: not started).
    Child *observer(const std::string &name);
    const Child *observer(const std::string &name) const;

    void reap();   // every child that has ended, without waiting
    bool all_exited() const;
    // A run's process that died before the simulator said done (or with an
    // error), named with its exit code and log; "" when none.
    std::string dead(const Progress &prog, const std::string &out) const;
    // The live run's processes.
    std::vector<std::string> live() const;
    // SIGKILL to the run's process `name` (--kill).
    void kill_named(const std::string &name);
    // Where each one really runs (read once the run starts).
    void read_cpus();
    // sig to every run's process still alive.
    void signal_run(int sig);
    // SIGKILL to the rest, each waited for.
    void kill_run();
    void stop_view_bridge();
    // lcm-spy stays open for the person watching until they close it, or
    // on SIGINT or SIGTERM; closed at once when the run failed.
    void close_spy(bool failed);
    // Each run's process's CPU with its descendants, and the launcher's own.
    CpuReading cpu_reading() const;

private:
    std::vector<Child> run_;
    std::vector<Child> observers_;
};

}  // namespace afm::launch
