// The frames for a person watching (./afm run SCENE --view, docs/view.md):
// each composed frame, JPEG-encoded, on VIEW_FRAME (lcmtypes/view_frame_t.lcm)
// with the state the page draws over it and the force of the blocks since
// the previous one, published by a thread of the renderer's own.
//
// Contract:
//   - An observer of an observer: offer() and sample() never wait for the
//     encoder. A frame offered while the previous one waits is replaced by
//     it and counted (view_frame_t.skipped; report()["skipped"]); a person
//     sees the newest frame, and the lockstep never slows down for a page.
//   - Nothing else is lost: the samples of a skipped frame go with the next
//     one (at most kMaxSamples wait; past that the oldest go, counted).
//   - A message stays under LCM's short message (kMaxMessageBytes): the
//     JPEG's quality is lowered until it fits, so that the kernel's filter
//     (bus/bus_filter.hpp) keeps it from every process that did not ask
//     for it; a frame that fits at no quality is dropped and counted.
//   - The frame's pixels are shared with the frame writer, never written.
//   - finish() publishes the frame waiting, then stops the thread.
#pragma once

#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "afm/haptic_force_t.hpp"
#include "afm/view_frame_t.hpp"
#include "worker.hpp"

namespace afm {

class ViewFrames {
public:
    static constexpr std::size_t kMaxMessageBytes = 60000;   // LCM's short message holds 65499 bytes with the channel
    static constexpr std::size_t kMaxSamples = 2048;
    static constexpr int kQuality = 85, kLowestQuality = 30;

    // sample_every_blocks: one block in so many goes to the strip chart.
    // cpus: where the thread may run (empty: the process's CPUs; the
    // renderer passes none, so that the encoding stays on the observers'
    // CPU: on every CPU of the run, as the frame writer, it cost the
    // lockstep 19 % a block against 3 %, docs/view.md). The bus is opened
    // here (a socket of its own; bus/bus.hpp).
    ViewFrames(int sample_every_blocks, std::vector<int> cpus);
    ~ViewFrames();
    ViewFrames(const ViewFrames &) = delete;
    ViewFrames &operator=(const ViewFrames &) = delete;

    // A block's forces (HAPTIC_FORCE), for the strip chart.
    void sample(const haptic_force_t &m);
    // A composed frame and its state (every field but the samples and the
    // JPEG filled in); replaces one not yet taken by the thread.
    void offer(cv::Mat frame, view_frame_t state);
    // Publishes what waits and stops the thread.
    void finish();

    // published, skipped, too_large, samples_dropped, encode_ms_per_frame
    // (the thread's CPU), bytes_per_frame (mean), jpeg_quality_min.
    nlohmann::json report() const;

private:
    struct Offer {
        cv::Mat frame;
        view_frame_t msg;
    };
    void publish(Offer o, int skipped);
    bool encode(const cv::Mat &frame, view_frame_t *msg);

    const int every_;
    std::unique_ptr<lcm::LCM> lc_;
    mutable std::mutex m_;
    std::vector<haptic_force_t> samples_;
    int64_t published_ = 0, skipped_ = 0, too_large_ = 0, samples_dropped_ = 0, bytes_ = 0;
    int quality_min_ = kQuality;
    Worker<Offer> worker_;   // the thread (common/worker.hpp): one frame waits, the newest
};

}  // namespace afm
