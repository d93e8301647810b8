#include "progress.hpp"

#include <cstdio>

#include "lockstep.hpp"
#include "scene.hpp"

namespace afm::launch {

void Progress::restart_clocks(Clock::time_point now)
{
    for (auto &kv : progress_at) kv.second = now;
}

std::string Progress::stalled(const std::vector<std::string> &live, double stall_s, Clock::time_point start, Clock::time_point now) const
{
    for (const auto &name : live) {
        const auto it = progress_at.find(name);
        const auto since = it == progress_at.end() ? start : it->second;
        if (std::chrono::duration<double>(now - since).count() > stall_s && !is(name, RunState::done)) return name;
    }
    return "";
}

double Progress::sim_seconds() const
{
    const auto it = last.find("sim_afm");
    return it == last.end() ? 0.0 : it->second.sim_utime * 1e-6;
}

bool Progress::sim_loop_over(int64_t total_blocks) const
{
    const auto it = last.find("sim_afm");
    if (it == last.end()) return false;
    return it->second.state == state_text(RunState::done) || it->second.seq >= total_blocks - 1;
}

std::string Progress::line(const Scene &scene, bool started, double wall_s) const
{
    char buf[160];
    if (!started) {
        std::snprintf(buf, sizeof buf, "run: starting (scan, processes)   wall %.1f s   ", wall_s);
        return buf;
    }
    int frames = 0;
    const auto r = last.find("renderer");
    if (r != last.end() && r->second.sim_utime > 0) frames = frames_due(scene, r->second.sim_utime);
    std::snprintf(buf, sizeof buf, "run: sim %.2f / %.2f s   frames %d / %d   wall %.1f s   ", sim_seconds(), scene.duration_s, frames,
                  scene.total_frames(), wall_s);
    return buf;
}

}  // namespace afm::launch
