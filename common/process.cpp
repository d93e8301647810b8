#include "process.hpp"

#include <nlohmann/json.hpp>

#include <sys/prctl.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>

namespace afm {

const char *state_text(RunState s)
{
    switch (s) {
    case RunState::starting: return "starting";
    case RunState::ready: return "ready";
    case RunState::running: return "running";
    case RunState::finished: return "finished";
    case RunState::ending: return "ending";
    case RunState::done: return "done";
    case RunState::stop: return "stop";
    }
    return "?";
}

bool says(const heartbeat_t &m, const char *name, RunState s) { return m.name == name && m.state == state_text(s); }

bool run_over(const heartbeat_t &m) { return says(m, "sim_afm", RunState::done) || says(m, "launcher", RunState::stop); }

void write_report(const std::string &path, const nlohmann::json &j)
{
    const std::string tmp = path + ".tmp";
    {
        std::ofstream f(tmp);
        f << j.dump(2) << "\n";
        f.flush();
        if (!f) {
            const int err = errno;
            std::remove(tmp.c_str());
            throw std::runtime_error("cannot write " + path + (err ? std::string(": ") + std::strerror(err) : std::string()));
        }
    }
    if (std::rename(tmp.c_str(), path.c_str()) != 0) {
        const int err = errno;
        std::remove(tmp.c_str());
        throw std::runtime_error("cannot write " + path + ": " + std::strerror(err));
    }
}

bool bind_to_parent(pid_t parent)
{
    prctl(PR_SET_PDEATHSIG, SIGKILL);
    return getppid() == parent;   // after the bind: a parent gone before it is seen here
}

bool bind_to_launcher(pid_t *parent)
{
    if (parent) *parent = 0;
    const char *env = std::getenv(kLauncherPidEnv);
    if (!env || !*env) return true;
    char *end = nullptr;
    const long pid = std::strtol(env, &end, 10);
    if (*end || pid <= 1) return true;   // not a pid the launcher wrote: nothing to bind to
    if (parent) *parent = static_cast<pid_t>(pid);
    return bind_to_parent(static_cast<pid_t>(pid));
}

}  // namespace afm
