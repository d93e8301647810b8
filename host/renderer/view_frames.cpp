#include "view_frames.hpp"

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <utility>

#include "afm_channels.h"
#include "bus.hpp"
#include "placement.hpp"

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
    : every_(sample_every_blocks > 0 ? sample_every_blocks : 1), lc_(open_bus())
{
    thread_ = start_pinned(std::move(cpus), "renderer: the view frames", [this] { run(); });
}

ViewFrames::~ViewFrames()
{
    {
        std::lock_guard<std::mutex> l(m_);
        stop_ = true;
        pending_.reset();
    }
    work_.notify_one();
    if (thread_.joinable()) thread_.join();
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
    {
        std::lock_guard<std::mutex> l(m_);
        if (pending_) ++skipped_pending_;
        pending_ = Offer{std::move(frame), std::move(state)};
    }
    work_.notify_one();
}

void ViewFrames::finish()
{
    {
        std::lock_guard<std::mutex> l(m_);
        stop_ = true;
    }
    work_.notify_one();
    if (thread_.joinable()) thread_.join();
}

void ViewFrames::run()
{
    std::unique_lock<std::mutex> l(m_);
    while (true) {
        work_.wait(l, [&] { return stop_ || pending_; });
        if (!pending_) return;   // stopped, nothing waits
        Offer o = std::move(*pending_);
        pending_.reset();
        std::vector<haptic_force_t> samples;
        samples.swap(samples_);
        const int skipped = skipped_pending_;
        skipped_pending_ = 0;
        l.unlock();
        const double t0 = thread_cpu_seconds();
        publish(std::move(o), std::move(samples), skipped);
        l.lock();
        cpu_s_ += thread_cpu_seconds() - t0;
        skipped_ += skipped;
    }
}

void ViewFrames::publish(Offer o, std::vector<haptic_force_t> samples, int skipped)
{
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
        cv::imencode(".jpg", frame, jpeg, {cv::IMWRITE_JPEG_QUALITY, q});
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
    std::lock_guard<std::mutex> l(m_);
    return {{"published", published_},
            {"skipped", skipped_},
            {"too_large", too_large_},
            {"samples_dropped", samples_dropped_},
            {"encode_ms_per_frame", published_ ? 1e3 * cpu_s_ / published_ : 0.0},
            {"bytes_per_frame", published_ ? bytes_ / published_ : 0},
            {"jpeg_quality_min", quality_min_}};
}

}  // namespace afm
