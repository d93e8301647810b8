// Where a run's processes run: the lockstep's three processes (sim_afm,
// fw_node, operator) share one CPU, and the observers (the launcher, which
// records the bus, the renderer, lcm-spy) run on the others.
//
// Why (measured by ./afm bench bus, docs/bus.md "The latency model"): a
// block of the lockstep is a chain of datagrams, each one waking a thread of
// the next process. When the next process sleeps on another CPU, the wake-up
// is an inter-processor interrupt, which on a virtual machine costs a trip
// through the hypervisor on both sides; the three processes of the chain on
// one CPU wake each other on that CPU. The chain never runs two of them at
// once (each waits for the other's datagram), so one CPU loses nothing, and
// the observers' work (recording, composing and encoding frames) moves off
// the chain's CPU.
//
// Concurrent runs (a sweep's points, two runs at once) each take a
// different CPU for their lockstep: a run holds an exclusive flock on
// `<lock_dir>/afm-lockstep-cpu<N>.lock` for the CPU it took, for as long as
// the Placement lives (the descriptor is close-on-exec, and the launcher's
// children close every inherited descriptor). When every CPU the launcher
// may use is taken, or it may use only one, or placement is off, nothing
// is pinned and the kernel places the processes as it likes.
#pragma once

#include <sys/types.h>

#include <functional>
#include <string>
#include <thread>
#include <vector>

namespace afm {

// The CPUs this process may run on (its affinity mask), ascending.
std::vector<int> allowed_cpus();

// Pins the calling process (every thread it starts later inherits it) to
// `cpus`. Empty: does nothing. Returns false (errno set) if the kernel refuses.
bool pin_self(const std::vector<int> &cpus);

// Starts a thread that pins itself to `cpus` (sched_setaffinity on the
// thread: it alone; empty: where the kernel puts it), then runs `body`. A
// pin the kernel refuses is reported on stderr, naming `what`, and the
// thread runs unpinned.
std::thread start_pinned(std::vector<int> cpus, std::string what, std::function<void()> body);

// The CPU time the calling thread has used, seconds (CLOCK_THREAD_CPUTIME_ID;
// 0 where the clock is refused): a worker thread's own cost, as the
// renderer's frame writer and view frames report it.
double thread_cpu_seconds();

// The CPUs process `pid` may run on, ascending; empty if it cannot be read.
std::vector<int> cpus_of(pid_t pid);

// "0", "1-3", "0,2-3": a CPU list as the kernel writes one.
std::string cpu_list(const std::vector<int> &cpus);
// The reverse: "" is no CPU; false (cpus untouched) for anything cpu_list()
// would not write (not ascending, a CPU past CPU_SETSIZE, stray text). A
// process's CPU-list option (--aside-cpus) reads it: command_line.hpp's read_cpus.
bool parse_cpu_list(const std::string &text, std::vector<int> *cpus);

class Placement {
public:
    // No placement: everything where the kernel puts it.
    Placement() = default;
    // Chooses the lockstep's CPU among `allowed` (the first whose lock file
    // in `lock_dir` is free) and gives the observers the rest. With fewer
    // than two CPUs, or every one of them taken, no placement; why() says so.
    Placement(const std::vector<int> &allowed, const std::string &lock_dir);
    ~Placement();
    Placement(Placement &&o) noexcept;
    Placement &operator=(Placement &&o) noexcept;
    Placement(const Placement &) = delete;
    Placement &operator=(const Placement &) = delete;

    bool on() const { return !lockstep_.empty(); }
    // The CPUs of a process by its name: the lockstep's for sim_afm, fw_node
    // and operator, the observers' for any other; empty when not placed.
    const std::vector<int> &cpus_for(const std::string &process) const;
    const std::vector<int> &lockstep() const { return lockstep_; }
    const std::vector<int> &observers() const { return observers_; }
    // Both, ascending: every CPU the run may use.
    std::vector<int> all() const;
    // Why there is no placement ("" when there is one).
    const std::string &why() const { return why_; }

    // The processes that make the lockstep's chain.
    static bool in_lockstep(const std::string &process);
    // Where the lock files go by default.
    static constexpr const char *kLockDir = "/tmp";

private:
    std::vector<int> lockstep_, observers_;
    std::string why_ = "placement off";
    int lock_fd_ = -1;
};

}  // namespace afm
