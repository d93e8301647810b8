#include "children.hpp"

#include <fcntl.h>
#include <sched.h>
#include <unistd.h>

#include <dirent.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "bus_key.hpp"
#include "placement.hpp"
#include "senders.hpp"

namespace afm::launch {

int udp_sockets_on_port(int port)
{
    // each line after the header: "sl local_address(HEX_IP:HEX_PORT) rem_address ..."
    int n = 0;
    for (const char *path : {"/proc/net/udp", "/proc/net/udp6"}) {
        std::ifstream in(path);
        std::string line;
        std::getline(in, line);
        while (std::getline(in, line)) {
            std::istringstream row(line);
            std::string slot, local;
            row >> slot >> local;
            const auto colon = local.rfind(':');
            if (colon != std::string::npos && std::strtol(local.c_str() + colon + 1, nullptr, 16) == port) ++n;
        }
    }
    return n;
}

namespace {

// CPU time (ns) of every thread of process pid (/proc/PID/task/*/schedstat).
long long threads_cpu_ns(int pid)
{
    const std::string dir = "/proc/" + std::to_string(pid) + "/task";
    DIR *d = opendir(dir.c_str());
    if (!d) return -1;
    long long ns = 0;
    while (const dirent *e = readdir(d)) {
        if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
        std::ifstream f(dir + "/" + e->d_name + "/schedstat");
        long long on_cpu = 0;
        if (f >> on_cpu) ns += on_cpu;
    }
    closedir(d);
    return ns;
}

}  // namespace

double tree_cpu_seconds(pid_t root, double *descendants_s)
{
    // every process's parent (Senders::parent_pid, the one reader of /proc/PID/stat's ppid)
    std::multimap<int, int> kids;
    if (DIR *d = opendir("/proc")) {
        while (const dirent *e = readdir(d)) {
            char *end = nullptr;
            const long pid = std::strtol(e->d_name, &end, 10);
            if (*end || pid <= 0) continue;
            const int ppid = afm::Senders::parent_pid(static_cast<int>(pid));
            if (ppid > 0) kids.emplace(ppid, static_cast<int>(pid));
        }
        closedir(d);
    }
    const long long own = threads_cpu_ns(root);
    if (own < 0) return -1;
    long long ns = own;
    std::vector<int> todo;
    for (auto [it, last] = kids.equal_range(root); it != last; ++it) todo.push_back(it->second);
    while (!todo.empty()) {
        const int pid = todo.back();
        todo.pop_back();
        const long long t = threads_cpu_ns(pid);
        if (t > 0) ns += t;
        for (auto [it, last] = kids.equal_range(pid); it != last; ++it) todo.push_back(it->second);
    }
    if (descendants_s) *descendants_s = (ns - own) * 1e-9;
    return ns * 1e-9;
}

namespace {

// Enters the user namespace of process `pid`, then (net) its network
// namespace; false (errno set) if either refuses.
bool enter_namespaces_of(int pid, bool net)
{
    for (const auto &[kind, flag] : {std::pair<const char *, int>{"user", CLONE_NEWUSER}, {"net", CLONE_NEWNET}}) {
        if (flag == CLONE_NEWNET && !net) break;
        const int fd = open(("/proc/" + std::to_string(pid) + "/ns/" + kind).c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0 || setns(fd, flag) != 0) return false;
        close(fd);
    }
    return true;
}

// fd at `slot` in this process, inherited at exec (dup2 clears
// close-on-exec; fd already there keeps its flag, cleared by hand).
bool put_at(int fd, int slot)
{
    return fd == slot ? fcntl(slot, F_SETFD, 0) == 0 : dup2(fd, slot) == slot;
}

// In spawn's child: the key at kBusKeyFd and pass_fd at kPassedFd, each
// slot closed when it has none; what is above them is the launcher's
// (spawn closes it). Returns the first descriptor above them, or -1 (said)
// when one cannot be placed.
int place_inherited(int key_fd, int pass_fd, const char *who)
{
    // the passed descriptor out of the key's slot first
    if (pass_fd == kBusKeyFd) pass_fd = fcntl(pass_fd, F_DUPFD, kPassedFd + 1);
    if (key_fd < 0) {
        close(kBusKeyFd);
    } else if (!put_at(key_fd, kBusKeyFd)) {
        std::fprintf(stderr, "afm_launch: cannot hand the bus key to %s: %s\n", who, std::strerror(errno));
        return -1;
    }
    if (pass_fd == -1) return key_fd >= 0 ? kBusKeyFd + 1 : kBusKeyFd;
    if (pass_fd < 0 || !put_at(pass_fd, kPassedFd)) {
        std::fprintf(stderr, "afm_launch: cannot hand descriptor %d to %s: %s\n", kPassedFd, who, std::strerror(errno));
        return -1;
    }
    return kPassedFd + 1;
}

}  // namespace

pid_t spawn(const std::vector<std::string> &argv, const std::string &log_path, const std::vector<std::string> &env_add,
            int nice_level, const std::vector<int> &cpus, Entry entry, int key_fd, int pass_fd)
{
    const std::string key_env = std::string(kBusKeyFdEnv) + "=" + std::to_string(kBusKeyFd);
    const pid_t launcher = getpid();
    const std::string launcher_env = std::string(kLauncherPidEnv) + "=" + std::to_string(launcher);
    pid_t pid = fork();
    if (pid < 0) throw std::runtime_error(std::string("fork failed: ") + std::strerror(errno));
    if (pid == 0) {
        setpgid(0, 0);
        if (nice_level) setpriority(PRIO_PROCESS, 0, nice_level);
        // before exec, so that every thread it starts is placed too
        if (!pin_self(cpus)) std::fprintf(stderr, "afm_launch: cannot pin %s to CPUs %s: %s\n", argv[0].c_str(),
                                                cpu_list(cpus).c_str(), std::strerror(errno));
        int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) {
            dup2(fd, 1);
            dup2(fd, 2);
            close(fd);
        }
        if (entry.ns_pid > 0 && !enter_namespaces_of(entry.ns_pid, entry.net)) {
            std::fprintf(stderr, "afm_launch: cannot enter the namespaces of pid %d for %s: %s\n", entry.ns_pid, argv[0].c_str(),
                         std::strerror(errno));
            _exit(127);
        }
        int devnull = open("/dev/null", O_RDONLY);
        if (devnull >= 0) dup2(devnull, 0);
        // the run's key at kBusKeyFd, the passed descriptor at kPassedFd
        const int keep = place_inherited(key_fd, pass_fd, argv[0].c_str());
        if (keep < 0) _exit(127);
        if (key_fd >= 0) putenv(const_cast<char *>(key_env.c_str()));
        // nothing else of the launcher's: its bus socket, its log
        if (close_range(static_cast<unsigned>(keep), ~0u, 0) != 0)
            for (int k = keep, top = static_cast<int>(sysconf(_SC_OPEN_MAX)); k < top && k < 65536; ++k) close(k);
        for (const auto &e : env_add) putenv(const_cast<char *>(e.c_str()));
        putenv(const_cast<char *>(launcher_env.c_str()));   // the child binds itself again after drop_caps.sh (process.hpp)
        // the run dies with the launcher: bound after entering the namespaces
        // (a change of credentials clears the binding), just before exec
        if (!bind_to_parent(launcher)) _exit(127);
        std::vector<char *> a;
        for (const auto &s : argv) a.push_back(const_cast<char *>(s.c_str()));
        a.push_back(nullptr);
        execv(a[0], a.data());
        std::fprintf(stderr, "afm_launch: cannot execute %s: %s\n", a[0], std::strerror(errno));
        _exit(127);
    }
    return pid;
}


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



}  // namespace afm::launch
