// The launcher's children (supervisor.hpp starts them): starting one
// (spawn), reaping it with the kernel's accounting (Child), the CPU of a
// process tree, sockets on the bus's port, and the tail of a child's log.
// (Progress, the heartbeats of the run's processes, is progress.hpp's.)
#pragma once

#include <sys/resource.h>
#include <sys/types.h>
#include <sys/wait.h>

#include <chrono>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "afm/heartbeat_t.hpp"
#include "bus_key.hpp"
#include "inbox.hpp"
#include "process.hpp"
#include "progress.hpp"

namespace afm::launch {

struct Child {
    std::string name;
    pid_t pid = -1;
    int exit_code = -1;       // exit status, or 128 + signal
    bool exited = false;
    std::string cpus = "";    // the CPUs it may run on, read once it is ready ("" before)
    double cpu_user_s = 0;    // the kernel's accounting of the child (wait4), user CPU seconds
    double cpu_system_s = 0;  // and system CPU seconds
    long max_rss_kb = 0;      // its peak resident memory, kB
    std::chrono::steady_clock::time_point exited_at = {};   // when reap() found it ended

    // Reaps the child if it has ended (block: wait for it); records its
    // exit status and the kernel's accounting of its resources.
    void reap(bool block = false)
    {
        if (exited || pid <= 0) return;
        int st;
        struct rusage ru {};
        if (wait4(pid, &st, block ? 0 : WNOHANG, &ru) != pid) return;
        exited = true;
        exited_at = std::chrono::steady_clock::now();
        exit_code = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
        cpu_user_s = ru.ru_utime.tv_sec + ru.ru_utime.tv_usec * 1e-6;
        cpu_system_s = ru.ru_stime.tv_sec + ru.ru_stime.tv_usec * 1e-6;
        max_rss_kb = ru.ru_maxrss;
    }
};

// Starts argv[0] with its output to log_path, env_add added to its
// environment, at nice_level, pinned to `cpus` (none: where the kernel puts
// it). entry.ns_pid > 0: in the user namespace of that process first, and
// (entry.net) its network namespace too (a two-host run, hosts.hpp);
// argv[0] must then drop what entering gives (run/drop_caps.sh).
// The child is bound to the launcher (process.hpp, bind_to_parent: SIGKILL
// when the launcher ends, however it ends) and finds the launcher's pid in
// kLauncherPidEnv, to bind itself again after drop_caps.sh.
struct Entry {
    int ns_pid = -1;
    bool net = false;
};
// key_fd >= 0: the run's bus key (bus_key.hpp), found by the child at
// kBusKeyFd and named by kBusKeyFdEnv. pass_fd >= 0: one more descriptor
// (afm_view_bridge's pipe to the page's server), found by the child at
// kPassedFd. Nothing else of the launcher's is inherited.
constexpr int kPassedFd = kBusKeyFd + 1;
pid_t spawn(const std::vector<std::string> &argv, const std::string &log_path, const std::vector<std::string> &env_add,
            int nice_level, const std::vector<int> &cpus, Entry entry = {}, int key_fd = -1, int pass_fd = -1);

// CPU time (s) on a CPU so far of process `root` and of every descendant
// alive now (QEMU under fw_node, ffmpeg under the renderer), all threads:
// the sum of /proc/PID/task/TID/schedstat's first field (ns, exact, unlike
// the ticks of /proc/PID/stat). -1 when root is gone. descendants_s (if
// given): the descendants' part.
double tree_cpu_seconds(pid_t root, double *descendants_s = nullptr);

// UDP sockets bound to local `port` in this network namespace (IPv4 and
// IPv6: /proc/net/udp, /proc/net/udp6); 0 when neither reads.
int udp_sockets_on_port(int port);

// The last max_lines lines of a file, each indented by four spaces.
std::string slurp_tail(const std::string &path, std::size_t max_lines);

}  // namespace afm::launch
