#include "view_frames.hpp"

#include <algorithm>
#include <utility>

#include "afm_channels.h"
#include "bus.hpp"
#include "jpeg_file.hpp"

namespace afm {

namespace {

// The message's bytes without its image.
std::size_t bytes_without_image(const view_frame_t &m)
{
    view_frame_t copy = m;
    copy.n_jpeg = 0;
    copy.jpeg.clear();
    return static_cast<std::size_t>(copy.getEncodedSize());
}

}  // namespace

ViewFrames::ViewFrames(int sample_every_blocks, std::vector<int> cpus)
    : every_(sample_every_blocks > 0 ? sample_every_blocks : 1), lc_(open_bus()),
      worker_({1, Full::replace, 0, 1},
              [this](std::vector<Offer> &one, int64_t skipped) { publish(std::move(one.front()), static_cast<int>(skipped)); })
{
    worker_.start(std::move(cpus), "renderer: the view frames");
}

ViewFrames::~ViewFrames()
{
    worker_.stop(Stop::discard);
}

void ViewFrames::sample(const haptic_force_t &m)
{
    if (m.seq % every_ != 0) return;
    std::lock_guard<std::mutex> l(m_);
    if (samples_.size() >= kMaxSamples) {
        samples_.erase(samples_.begin());
        ++samples_dropped_;
    }
    samples_.push_back(m);
}

void ViewFrames::offer(cv::Mat frame, view_frame_t state)
{
    worker_.post(Offer{std::move(frame), std::move(state)});
}

void ViewFrames::finish()
{
    worker_.stop(Stop::drain);
}

// On the thread: the frame taken with the samples since the previous one.
void ViewFrames::publish(Offer o, int skipped)
{
    std::vector<haptic_force_t> samples;
    {
        std::lock_guard<std::mutex> l(m_);
        samples.swap(samples_);
        skipped_ += skipped;
    }
    view_frame_t &m = o.msg;
    m.skipped = skipped;
    m.n_samples = static_cast<int32_t>(samples.size());
    for (const auto &s : samples) {
        m.sample_utime.push_back(s.utime);
        m.sample_fx_nN.push_back(s.tip_force_nN[0]);
        m.sample_fy_nN.push_back(s.tip_force_nN[1]);
        m.sample_fz_nN.push_back(s.tip_force_nN[2]);
        m.sample_hand_x_N.push_back(s.force_N[0]);
        m.sample_hand_y_N.push_back(s.force_N[1]);
        m.sample_hand_z_N.push_back(s.force_N[2]);
    }
    if (!encode(o.frame, &m)) {
        std::lock_guard<std::mutex> l(m_);
        ++too_large_;
        return;
    }
    afm::publish(*lc_, AFM_CH_VIEW_FRAME, m);
    std::lock_guard<std::mutex> l(m_);
    ++published_;
    bytes_ += m.getEncodedSize();
}

// The frame as a JPEG that fits the message beside its other fields: at
// kQuality, or lower by steps of 10 down to kLowestQuality.
bool ViewFrames::encode(const cv::Mat &frame, view_frame_t *msg)
{
    const std::size_t room = kMaxMessageBytes - std::min(kMaxMessageBytes, bytes_without_image(*msg));
    std::vector<unsigned char> jpeg;
    for (int q = kQuality; q >= kLowestQuality; q -= 10) {
        jpeg = encode_jpeg(frame, q);
        if (jpeg.size() <= room) {
            msg->jpeg = std::move(jpeg);
            msg->n_jpeg = static_cast<int32_t>(msg->jpeg.size());
            std::lock_guard<std::mutex> l(m_);
            quality_min_ = std::min(quality_min_, q);
            return true;
        }
    }
    return false;
}

nlohmann::json ViewFrames::report() const
{
    const double cpu_s = worker_.counts().cpu_s;
    std::lock_guard<std::mutex> l(m_);
    return {{"published", published_},
            {"skipped", skipped_},
            {"too_large", too_large_},
            {"samples_dropped", samples_dropped_},
            {"encode_ms_per_frame", published_ ? 1e3 * cpu_s / published_ : 0.0},
            {"bytes_per_frame", published_ ? bytes_ / published_ : 0},
            {"jpeg_quality_min", quality_min_}};
}

}  // namespace afm
