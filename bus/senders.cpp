#include "senders.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <unistd.h>

#include <cerrno>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include "afm/heartbeat_t.hpp"
#include "afm_channels.h"
#include "text.hpp"

namespace afm {

namespace {

int64_t now_us()
{
    return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Socket inode -> local port of every UDP socket of the network namespace
// `pid` is in (/proc/PID/net/udp and udp6: "sl local_address rem_address st
// ... inode"): a run of two hosts has its processes in two namespaces.
std::map<unsigned long, uint16_t> udp_inodes(int pid)
{
    std::map<unsigned long, uint16_t> out;
    const std::string net = "/proc/" + std::to_string(pid) + "/net/";
    for (const std::string &path : {net + "udp", net + "udp6"}) {
        std::ifstream f(path);
        std::string line;
        std::getline(f, line);   // the header
        while (std::getline(f, line)) {
            std::istringstream in(line);
            std::string sl, local, remote, st, queues, timer, retr, uid, timeout;
            unsigned long inode = 0;
            if (!(in >> sl >> local >> remote >> st >> queues >> timer >> retr >> uid >> timeout >> inode)) continue;
            const auto colon = local.rfind(':');
            if (colon == std::string::npos || inode == 0) continue;
            out[inode] = static_cast<uint16_t>(std::strtoul(local.c_str() + colon + 1, nullptr, 16));
        }
    }
    return out;
}

// The text of a small /proc file, or "" when it cannot be read. A process
// that exits while its file is read makes read() fail with ESRCH, which
// libstdc++'s istreambuf_iterator turns into an uncaught std::ios_failure
// (a sweep's run aborted so, exit 134): plain read(), errors taken as "".
std::string read_proc(const std::string &path)
{
    std::string out;
    const int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return out;
    char buf[4096];
    for (;;) {
        const ssize_t n = read(fd, buf, sizeof buf);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) break;
        out.append(buf, static_cast<std::size_t>(n));
    }
    ::close(fd);
    return out;
}

// The parent pid of `pid` (/proc/PID/stat's fourth field), or -1.
int parent_of(int pid)
{
    const std::string s = read_proc("/proc/" + std::to_string(pid) + "/stat");
    const auto close = s.rfind(')');
    if (close == std::string::npos) return -1;
    std::istringstream in(s.substr(close + 1));
    std::string state;
    int ppid = -1;
    in >> state >> ppid;
    return ppid;
}

std::vector<int> children_of(int parent)
{
    std::vector<int> out;
    DIR *d = opendir("/proc");
    if (!d) return out;
    while (dirent *e = readdir(d)) {
        char *end = nullptr;
        const long pid = std::strtol(e->d_name, &end, 10);
        if (*end == '\0' && pid > 0 && parent_of(static_cast<int>(pid)) == parent) out.push_back(static_cast<int>(pid));
    }
    closedir(d);
    return out;
}

std::string program_of(int pid)
{
    char buf[4096];
    const ssize_t n = readlink(("/proc/" + std::to_string(pid) + "/exe").c_str(), buf, sizeof buf - 1);
    if (n <= 0) return "";
    std::string exe(buf, static_cast<std::size_t>(n));
    const std::string deleted = " (deleted)";   // rebuilt while it runs: still the same program
    if (exe.size() > deleted.size() && exe.compare(exe.size() - deleted.size(), deleted.size(), deleted) == 0)
        exe.resize(exe.size() - deleted.size());
    return exe.substr(exe.rfind('/') + 1);
}

// Socket inodes held by `pid` (its /proc/PID/fd links "socket:[N]").
std::vector<unsigned long> sockets_of(int pid)
{
    std::vector<unsigned long> out;
    const std::string dir = "/proc/" + std::to_string(pid) + "/fd";
    DIR *d = opendir(dir.c_str());
    if (!d) return out;
    char buf[64];
    while (dirent *e = readdir(d)) {
        const ssize_t n = readlink((dir + "/" + e->d_name).c_str(), buf, sizeof buf - 1);
        if (n <= 8) continue;
        buf[n] = '\0';
        unsigned long inode = 0;
        if (std::sscanf(buf, "socket:[%lu]", &inode) == 1) out.push_back(inode);
    }
    closedir(d);
    return out;
}

}  // namespace

Senders::Senders(Scope scope) : scope_(scope), any_(admit_any()) {}

bool Senders::admit_any()
{
    const char *any = std::getenv("AFM_ADMIT_ANY_SENDER");
    return any && std::string(any) == "1";
}

bool Senders::publishes(const std::string &program, const std::string &channel)
{
    bool ok = false;
#define AFM_SENDER_RULE(CH, WHO) \
    if (channel == CH && (std::string(WHO) == "*" || program == WHO)) ok = true;
    AFM_CHANNEL_PUBLISHERS(AFM_SENDER_RULE)
#undef AFM_SENDER_RULE
    return ok;
}

void Senders::rescan()
{
    std::set<int> run;
    if (scope_ == Scope::children) {
        run.insert(getpid());
        for (int c : children_of(getpid())) run.insert(c);
    } else {
        const int parent = getppid();
        run.insert(parent);
        for (int c : children_of(parent)) run.insert(c);
    }
    std::map<std::string, std::map<unsigned long, uint16_t>> by_netns;   // one read per namespace
    // The launcher of a two-host run is in the user namespace that holds the
    // run's: its file descriptors are closed to its children, so it names its
    // own ports in their environment (kParentPortsEnv); the parent's word,
    // like its pid.
    if (scope_ == Scope::siblings && sockets_of(getppid()).empty())
        if (const char *said = std::getenv(kParentPortsEnv)) {   // "PROGRAM:P,P,..."
            const std::string text = said;
            const auto colon = text.find(':');
            std::stringstream ss(colon == std::string::npos ? "" : text.substr(colon + 1));
            std::string p;
            while (std::getline(ss, p, ','))
                if (std::atoi(p.c_str()) > 0) owners_[static_cast<uint16_t>(std::atoi(p.c_str()))] = Owner{text.substr(0, colon), getppid()};
        }
    for (int pid : run) {
        char link[64] = "";
        const ssize_t n = readlink(("/proc/" + std::to_string(pid) + "/ns/net").c_str(), link, sizeof link - 1);
        const std::string ns = n > 0 ? std::string(link, static_cast<std::size_t>(n)) : std::to_string(pid);
        if (!by_netns.count(ns)) by_netns[ns] = udp_inodes(pid);
        const auto &ports = by_netns[ns];
        for (unsigned long inode : sockets_of(pid)) {
            auto it = ports.find(inode);
            if (it == ports.end() || it->second == 0) continue;
            owners_[it->second] = Owner{program_of(pid), pid};
        }
    }
}

int Senders::parent_pid(int pid)
{
    return parent_of(pid);
}

std::string Senders::own_ports()
{
    const auto ports = udp_inodes(getpid());
    std::string out;
    const std::string program = program_of(getpid()) + ":";
    for (unsigned long inode : sockets_of(getpid())) {
        auto it = ports.find(inode);
        if (it != ports.end() && it->second != 0) out += (out.empty() ? "" : ",") + std::to_string(it->second);
    }
    return program + out;
}

bool Senders::admit(const std::string &channel, uint16_t port)
{
    if (any_) return true;
    std::lock_guard<std::mutex> lock(m_);
    auto it = owners_.find(port);
    if (it == owners_.end()) {
        const int64_t second = now_us() / 1000000;
        if (second != scan_second_) {
            scan_second_ = second;
            scans_ = 0;
        }
        if (scans_ < kMaxScansPerSecond) {
            ++scans_;
            rescan();
            it = owners_.find(port);
            if (it == owners_.end()) it = owners_.emplace(port, Owner{}).first;   // no process of the run: remembered
        }
    }
    if (it != owners_.end() && !it->second.program.empty() && publishes(it->second.program, channel)) return true;
    count_foreign_locked(channel, port);
    return false;
}

bool Senders::vet(const std::string &channel, const unsigned char *data, std::size_t size, uint16_t port)
{
    if (any_ || channel != AFM_CH_AFM_HEARTBEAT || size > static_cast<std::size_t>(INT32_MAX)) return true;
    heartbeat_t hb;
    if (hb.decode(data, 0, static_cast<int>(size)) < 0) return true;
    const std::string program = hb.name == "launcher" ? "afm_launch" : hb.name;
    std::lock_guard<std::mutex> lock(m_);
    const auto it = owners_.find(port);
    if (it != owners_.end() && it->second.program == program) return true;
    ++foreign_[printable(channel)][describe(port) + " naming itself " + printable(hb.name)];
    ++foreign_total_;
    return false;
}

void Senders::count_foreign(const std::string &channel, uint16_t port)
{
    std::lock_guard<std::mutex> lock(m_);
    count_foreign_locked(channel, port);
}

void Senders::count_foreign_locked(const std::string &channel, uint16_t port)
{
    // a datagram names its channel with any bytes: kept as run.json shows it (text.hpp)
    ++foreign_[printable(channel)][describe(port)];
    ++foreign_total_;
}

std::string Senders::describe(uint16_t port) const
{
    auto it = owners_.find(port);
    if (it == owners_.end() || it->second.program.empty())
        return "port " + std::to_string(port) + " (no process of the run)";
    return "port " + std::to_string(port) + " (" + it->second.program + ", pid " + std::to_string(it->second.pid) + ")";
}

nlohmann::json Senders::foreign() const
{
    std::lock_guard<std::mutex> lock(m_);
    nlohmann::json j = nlohmann::json::object();
    for (const auto &[ch, by] : foreign_)
        for (const auto &[who, n] : by) j[ch][who] = n;
    return j;
}

int64_t Senders::foreign_count() const
{
    std::lock_guard<std::mutex> lock(m_);
    return foreign_total_;
}

}  // namespace afm
