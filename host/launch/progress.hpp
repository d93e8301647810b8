// The run's progress, as the launcher follows it: the heartbeats of the
// run's processes (the last of each, and when each last said something
// new), a stall (a live process silent on anything new for the stall
// time), the end of the simulator's loop, and the progress line.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "afm/heartbeat_t.hpp"
#include "inbox.hpp"
#include "process.hpp"

namespace afm {
struct Scene;
}

namespace afm::launch {

struct Progress {
    using Clock = std::chrono::steady_clock;
    // The processes whose heartbeats the launcher follows (the run's own,
    // set by Launch); another name is refused (out_of_range), so that
    // garbage cannot grow the tables.
    std::set<std::string> names;
    std::map<std::string, heartbeat_t> last;
    std::map<std::string, Clock::time_point> progress_at;

    // A heartbeat; progress when it says a new block or a new state (at `now`).
    Reject on_hb(const heartbeat_t &m, Clock::time_point now = Clock::now())
    {
        if (!names.count(m.name)) return Reject::out_of_range;
        auto it = last.find(m.name);
        if (it == last.end() || it->second.seq != m.seq || it->second.state != m.state) progress_at[m.name] = now;
        last[m.name] = m;
        return Reject::none;
    }
    bool is(const std::string &name, RunState state) const
    {
        auto it = last.find(name);
        return it != last.end() && it->second.state == state_text(state);
    }

    // The run starts (every process ready): each one's progress counts from `now`.
    void restart_clocks(Clock::time_point now);

    // The first of the live processes `live` that made no progress for
    // stall_s seconds up to `now` (since `start` when it never did) and is
    // not done; "" when none.
    std::string stalled(const std::vector<std::string> &live, double stall_s, Clock::time_point start, Clock::time_point now) const;

    // The simulator's time reached, s (its last heartbeat's).
    double sim_seconds() const;

    // The simulator's loop is over: its heartbeat for the last of
    // total_blocks (sent at once when the loop ends), or "done" (a run that
    // ended early).
    bool sim_loop_over(int64_t total_blocks) const;

    // What the simulator's last heartbeat says it scans ("K / N lines",
    // from its detail "scan K / N lines"), or "".
    std::string scanning() const;
    // The run's stage: "initial scan" (before the start: the renderer's
    // first scan, the processes starting), "loop", a scan in it ("loop, a
    // local scan", or "final scan" in the last frame period: the display's
    // check), "end" (the simulator's loop over); with a scan's lines.
    std::string stage(const Scene &scene, bool started) const;
    // The progress line (without its "\r"): the stage, then, once started,
    // simulated time and frames against the scene's, with the wall time.
    // Once the simulator's loop is over, the line also names the processes
    // the run still waits for and the block each has reached (finishing).
    std::string line(const Scene &scene, bool started, double wall_s) const;
    std::string finishing(const Scene &scene) const;
};

}  // namespace afm::launch
