#include "progress.hpp"

#include <cmath>
#include <cstdio>
#include <string>

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

std::string Progress::scanning() const
{
    const auto it = last.find("sim_afm");
    if (it == last.end() || it->second.detail.rfind("scan ", 0) != 0) return "";
    return it->second.detail.substr(5);   // "K / N lines"
}

std::string Progress::stage(const Scene &scene, bool started) const
{
    const std::string scan = scanning();
    if (!started) return scan.empty() ? "initial scan, processes starting" : "initial scan (" + scan + ")";
    if (sim_loop_over(scene.total_blocks())) return "end (processes finish)";
    if (scan.empty()) return "loop";
    // a scan asked in the last frame period is the display's check, the run's last
    const auto it = last.find("sim_afm");
    const int64_t frame = static_cast<int64_t>(std::ceil(scene.block_hz / scene.frame_rate_hz));
    const bool final = it != last.end() && it->second.seq >= scene.total_blocks() - 1 - frame;
    return (final ? "final scan (" : "loop, a local scan (") + scan + ")";
}

std::string Progress::line(const Scene &scene, bool started, double wall_s) const
{
    char buf[224];
    if (!started) {
        std::snprintf(buf, sizeof buf, "run: %s   wall %.1f s   ", stage(scene, false).c_str(), wall_s);
        return buf;
    }
    int frames = 0;
    const auto r = last.find("renderer");
    if (r != last.end() && r->second.sim_utime > 0) frames = frames_due(scene, r->second.sim_utime);
    std::snprintf(buf, sizeof buf, "run: %s   sim %.2f / %.2f s   frames %d / %d   wall %.1f s   ", stage(scene, true).c_str(), sim_seconds(),
                  scene.duration_s, frames, scene.total_frames(), wall_s);
    return buf + finishing(scene);
}

// Once the simulator's loop is over: the processes the run still waits
// for, each with the last block it said (the firmware under QEMU, which
// runs behind the simulator, or the renderer's video); "" before.
std::string Progress::finishing(const Scene &scene) const
{
    if (!sim_loop_over(scene.total_blocks())) return "";
    std::string waits;
    for (const auto &[name, hb] : last) {
        if (name == "sim_afm" || hb.state == state_text(RunState::done)) continue;
        waits += (waits.empty() ? "" : ", ") + name + " (block " + std::to_string(hb.seq + 1) + " / " +
                 std::to_string(scene.total_blocks()) + ")";
    }
    return waits.empty() ? "" : "simulation over; finishing: " + waits + "   ";
}

}  // namespace afm::launch
