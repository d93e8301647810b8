#include "process.hpp"

#include <nlohmann/json.hpp>

#include <cerrno>
#include <cstdio>
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

int run_process(const char *name, const std::function<int()> &body)
{
    try {
        return body();
    } catch (const InputError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return kExitInput;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "%s: %s\n", name, e.what());
        return kExitFailure;
    }
}

}  // namespace afm
