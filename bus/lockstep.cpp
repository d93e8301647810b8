#include "lockstep.hpp"

#include <algorithm>
#include <cmath>

namespace afm {

int64_t frame_utime(const Scene &s, int k) { return std::llround(k * 1e6 / s.frame_rate_hz); }

int64_t block_end_utime(const Scene &s, int64_t n) { return std::llround((n + 1) * 1e6 / s.block_hz); }

int frames_due(const Scene &s, int64_t t_us)
{
    int k = static_cast<int>(std::floor(t_us * 1e-6 * s.frame_rate_hz)) + 1;
    while (k > 0 && frame_utime(s, k - 1) > t_us) --k;
    while (frame_utime(s, k) <= t_us) ++k;
    return std::min(k, s.total_frames());
}

int local_scan_frame(const Scene &s, int i)
{
    const int64_t at_us = std::llround(s.op.local_scans.at(static_cast<std::size_t>(i)).at_s * 1e6);
    // at_s is within [0, duration_s] (load_scene), so k stays near total_frames()
    int k = std::max(0, static_cast<int>(std::floor(at_us * 1e-6 * s.frame_rate_hz)) - 1);
    while (frame_utime(s, k) < at_us) ++k;
    return k;
}

int frames_to_wait_for(const Scene &s, int64_t n, int64_t blocks)
{
    const int due = frames_due(s, block_end_utime(s, n));
    if (n + 1 >= blocks) return due;
    int need = std::max(0, due - kRendererWindowFrames);
    // the renderer's last frame, at the end of the run as it knows it (sim_afm's "ending")
    const int last = frames_due(s, block_end_utime(s, blocks - 1)) - 1;
    if (last < due) need = std::max(need, last + 1);
    for (int i = 0; i < static_cast<int>(s.op.local_scans.size()); ++i) {
        const int f = local_scan_frame(s, i);
        if (f >= due) break;   // in time order (load_scene)
        need = std::max(need, f + 1);
    }
    return need;
}

}  // namespace afm
