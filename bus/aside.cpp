#include "aside.hpp"

#include <chrono>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include "afm_channels.h"

#include "bus.hpp"
#include "placement.hpp"

namespace afm {

bool lockstep_reads(const Scene &s, const std::string &channel)
{
    static const char *const always[] = {AFM_CH_AFM_ANALOG,    AFM_CH_AFM_CMD,       AFM_CH_HAPTIC_FORCE,
                                         AFM_CH_HAPTIC_POSE,   AFM_CH_AFM_SCAN_REQ,  AFM_CH_AFM_SCAN_LINE,
                                         AFM_CH_HOST_OBJECT_FIX, AFM_CH_RENDER_FRAME, AFM_CH_AFM_HEARTBEAT};
    for (const char *c : always)
        if (channel == c) return true;
    // the planner steers on the objects (a run's, or a stroke the page asks for in operator.mode browser)
    return channel == AFM_CH_FW_STATE && (s.op.plan.enabled || s.op.mode == "browser");
}

void check_lockstep_reads(const Scene &s, const std::vector<std::string> &subscribed, const std::string &process)
{
    for (const auto &c : subscribed)
        if (!lockstep_reads(s, c))
            throw std::logic_error(process + " subscribes to " + c +
                                   ", which lockstep_reads() (bus/aside.hpp) does not name: its messages are published aside, "
                                   "a batch late; add it there");
}

Aside::Aside(std::vector<int> cpus, int batch_us, std::size_t max_queued)
    : lc_(open_bus()), batch_us_(batch_us > 0 ? batch_us : kBatchUs), max_queued_(max_queued > 0 ? max_queued : 1)
{
    thread_ = start_pinned(std::move(cpus), "aside: the publishing thread", [this] { run(); });
}

Aside::~Aside()
{
    {
        std::lock_guard<std::mutex> l(m_);
        stop_ = true;
    }
    wake_.notify_one();
    if (thread_.joinable()) thread_.join();
}

void Aside::post(const std::string &channel, const void *data, std::size_t size)
{
    const auto *p = static_cast<const uint8_t *>(data);
    Msg msg{channel, std::vector<uint8_t>(p, p + size)};
    std::unique_lock<std::mutex> l(m_);
    if (queue_.size() >= max_queued_) {
        ++waits_;
        hurry_ = true;
        wake_.notify_one();
        done_.wait(l, [&] { return queue_.size() < max_queued_; });
    }
    queue_.push_back(std::move(msg));
    ++posted_;
    // no notify: the thread takes the queue at its next batch (a wake-up
    // of a thread on another CPU costs more than the datagram)
}

void Aside::flush()
{
    std::unique_lock<std::mutex> l(m_);
    const int64_t want = posted_;
    hurry_ = true;
    wake_.notify_one();
    done_.wait(l, [&] { return published_ + failed_ >= want; });
}

int64_t Aside::published() const
{
    std::lock_guard<std::mutex> l(m_);
    return published_;
}

int64_t Aside::failed() const
{
    std::lock_guard<std::mutex> l(m_);
    return failed_;
}

int64_t Aside::waits() const
{
    std::lock_guard<std::mutex> l(m_);
    return waits_;
}

nlohmann::json Aside::report() const
{
    std::lock_guard<std::mutex> l(m_);
    return {{"published", published_}, {"failed", failed_}, {"waits", waits_}};
}

void Aside::run()
{
    std::vector<Msg> batch;
    std::unique_lock<std::mutex> l(m_);
    while (true) {
        wake_.wait_for(l, std::chrono::microseconds(batch_us_), [&] { return hurry_ || stop_; });
        hurry_ = false;
        const bool last = stop_;
        batch.swap(queue_);
        done_.notify_all();   // room in the queue
        l.unlock();
        int64_t ok = 0, bad = 0;
        for (const auto &m : batch) {
            if (publish_raw(*lc_, m.channel, m.data.data(), m.data.size()) == 0) ++ok;
            else ++bad;
        }
        batch.clear();
        l.lock();
        published_ += ok;
        failed_ += bad;
        done_.notify_all();   // flush() waits for this
        if (last && queue_.empty()) return;
    }
}

}  // namespace afm
