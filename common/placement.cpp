#include "placement.hpp"

#include <fcntl.h>
#include <sched.h>
#include <sys/file.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include <utility>

namespace afm {

namespace {

std::vector<int> cpus_in(const cpu_set_t &set)
{
    std::vector<int> out;
    for (int c = 0; c < CPU_SETSIZE; ++c)
        if (CPU_ISSET(c, &set)) out.push_back(c);
    return out;
}

const std::vector<int> kNone;

}  // namespace

std::vector<int> cpus_of(pid_t pid)
{
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(pid, sizeof set, &set) != 0) return {};
    return cpus_in(set);
}

std::vector<int> allowed_cpus() { return cpus_of(0); }

bool pin_self(const std::vector<int> &cpus)
{
    if (cpus.empty()) return true;
    cpu_set_t set;
    CPU_ZERO(&set);
    for (int c : cpus)
        if (c >= 0 && c < CPU_SETSIZE) CPU_SET(c, &set);
    return sched_setaffinity(0, sizeof set, &set) == 0;
}

std::thread start_pinned(std::vector<int> cpus, std::string what, std::function<void()> body)
{
    return std::thread([cpus = std::move(cpus), what = std::move(what), body = std::move(body)] {
        if (!pin_self(cpus))
            std::fprintf(stderr, "%s: cannot pin to CPUs %s: %s\n", what.c_str(), cpu_list(cpus).c_str(), std::strerror(errno));
        body();
    });
}

std::string cpu_list(const std::vector<int> &cpus)
{
    std::string out;
    for (std::size_t i = 0; i < cpus.size();) {
        std::size_t j = i;
        while (j + 1 < cpus.size() && cpus[j + 1] == cpus[j] + 1) ++j;
        if (!out.empty()) out += ",";
        out += std::to_string(cpus[i]);
        if (j > i) out += "-" + std::to_string(cpus[j]);
        i = j + 1;
    }
    return out;
}

bool parse_cpu_list(const std::string &text, std::vector<int> *cpus)
{
    std::vector<int> out;
    std::size_t i = 0;
    auto number = [&](int *v) {
        if (i >= text.size() || text[i] < '0' || text[i] > '9') return false;
        long n = 0;
        while (i < text.size() && text[i] >= '0' && text[i] <= '9') {
            n = n * 10 + (text[i++] - '0');
            if (n >= CPU_SETSIZE) return false;
        }
        *v = static_cast<int>(n);
        return true;
    };
    while (i < text.size()) {
        int a, b;
        if (!number(&a)) return false;
        b = a;
        if (i < text.size() && text[i] == '-') {
            ++i;
            if (!number(&b) || b < a) return false;
        }
        for (int c = a; c <= b; ++c)
            if (out.empty() || c > out.back()) out.push_back(c);
            else return false;   // not ascending, or repeated
        if (i < text.size() && text[i++] != ',') return false;
        if (i == text.size() && text.back() == ',') return false;
    }
    *cpus = std::move(out);
    return true;
}

std::vector<int> Placement::all() const
{
    std::vector<int> a = lockstep_;
    a.insert(a.end(), observers_.begin(), observers_.end());
    std::sort(a.begin(), a.end());
    return a;
}

bool Placement::in_lockstep(const std::string &process)
{
    return process == "sim_afm" || process == "fw_node" || process == "operator";
}

Placement::Placement(const std::vector<int> &allowed, const std::string &lock_dir)
{
    if (allowed.size() < 2) {
        why_ = "one CPU allowed (" + cpu_list(allowed) + "): nothing to place";
        return;
    }
    std::string trouble;   // a lock file that could not be used, other than taken
    for (int c : allowed) {
        const std::string path = lock_dir + "/afm-lockstep-cpu" + std::to_string(c) + ".lock";
        // Read-only is enough for flock; an existing file is opened without
        // O_CREAT, which fs.protected_regular refuses on another user's file.
        int fd = open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0 && errno == ENOENT) fd = open(path.c_str(), O_RDONLY | O_CREAT | O_CLOEXEC, 0666);
        if (fd < 0) {
            trouble = path + ": " + std::strerror(errno);
            continue;
        }
        if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
            if (errno != EWOULDBLOCK) trouble = path + ": " + std::strerror(errno);
            close(fd);
            continue;
        }
        lock_fd_ = fd;
        lockstep_ = {c};
        for (int o : allowed)
            if (o != c) observers_.push_back(o);
        why_.clear();
        return;
    }
    why_ = trouble.empty() ? "every CPU allowed (" + cpu_list(allowed) + ") holds another run's lockstep"
                           : "no lock file to take: " + trouble;
}

Placement::~Placement()
{
    if (lock_fd_ >= 0) close(lock_fd_);
}

Placement::Placement(Placement &&o) noexcept
    : lockstep_(std::move(o.lockstep_)), observers_(std::move(o.observers_)), why_(std::move(o.why_)), lock_fd_(std::exchange(o.lock_fd_, -1))
{
}

Placement &Placement::operator=(Placement &&o) noexcept
{
    if (this != &o) {
        if (lock_fd_ >= 0) close(lock_fd_);
        lockstep_ = std::move(o.lockstep_);
        observers_ = std::move(o.observers_);
        why_ = std::move(o.why_);
        lock_fd_ = std::exchange(o.lock_fd_, -1);
    }
    return *this;
}

const std::vector<int> &Placement::cpus_for(const std::string &process) const
{
    if (!on()) return kNone;
    return in_lockstep(process) ? lockstep_ : observers_;
}

double thread_cpu_seconds()
{
    timespec ts{};
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) != 0) return 0;
    return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

}  // namespace afm
