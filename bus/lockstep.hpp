// The lockstep's flow control between the simulator and the renderer, in a
// scene's simulated time: when frame k falls, which frames are due after a
// block, where a local scan is taken, and how far the renderer may fall
// behind before the simulator waits for it (sim_afm and the renderer both
// follow these rules; docs/bus.md, "The latency model"). Times are integer
// microseconds of simulated time from the run's start; frame and block
// numbers count from 0.
#pragma once

#include <cstdint>

#include "scene.hpp"

namespace afm {

// Simulated time (us) of frame k; the renderer and the simulator both use it.
int64_t frame_utime(const Scene &s, int k);
// Simulated time (us) at the end of block n (the state the block leaves).
int64_t block_end_utime(const Scene &s, int64_t n);
// Number of frames whose time is <= t_us (capped at total_frames()).
int frames_due(const Scene &s, int64_t t_us);
// The frame before which local scan i (op.local_scans[i]) is taken: the
// first whose time is at or after its at_s (total_frames() or more: after
// the run). The renderer asks for the scan there and the simulator waits
// there, so that the scan sees the same block every time.
int local_scan_frame(const Scene &s, int i);

// The renderer may fall this many frames behind the blocks the simulator
// has published before the simulator waits for it. Its inbox's receive
// thread queues what comes in memory (inbox.hpp, batched), so 2 frames of
// blocks wait there, not in its socket.
constexpr int kRendererWindowFrames = 2;
// The frames the renderer must have written before the simulator goes on
// after block n of a run of `blocks` blocks: all but the last
// kRendererWindowFrames of those due, but never short of a frame where the
// renderer asks for a scan (a local scan's, local_scan_frame; the run's
// last frame), so that the scan sees that frame's block whatever the
// timing (the simulator serves it while it waits); and every frame due at
// the last block.
int frames_to_wait_for(const Scene &s, int64_t n, int64_t blocks);

}  // namespace afm
