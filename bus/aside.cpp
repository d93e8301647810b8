#include "aside.hpp"

#include <stdexcept>
#include <utility>

#include "afm_channels.h"

#include "bus.hpp"

namespace afm {

bool lockstep_reads(const Scene &s, const std::string &channel)
{
    static const char *const always[] = {AFM_CH_AFM_ANALOG,    AFM_CH_AFM_CMD,       AFM_CH_HAPTIC_FORCE,
                                         AFM_CH_HAPTIC_POSE,   AFM_CH_AFM_SCAN_REQ,  AFM_CH_AFM_SCAN_LINE,
                                         AFM_CH_HOST_OBJECT_FIX, AFM_CH_RENDER_FRAME, AFM_CH_AFM_HEARTBEAT};
    for (const char *c : always)
        if (channel == c) return true;
    // the planner steers on the objects (a run's, or a stroke the page or a program asks for: operator.mode browser, env)
    return channel == AFM_CH_FW_STATE && (s.op.plan.enabled || s.op.mode == "browser" || s.op.mode == "env");
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
    : lc_(open_bus()),
      worker_({max_queued > 0 ? max_queued : 1, Full::block, batch_us > 0 ? batch_us : kBatchUs, 0},
              [this](std::vector<Msg> &batch, int64_t) { publish(batch); })
{
    worker_.start(std::move(cpus), "aside: the publishing thread");
}

Aside::~Aside()
{
    worker_.stop(Stop::drain);
}

void Aside::post(const std::string &channel, const void *data, std::size_t size)
{
    const auto *p = static_cast<const uint8_t *>(data);
    worker_.post(Msg{channel, std::vector<uint8_t>(p, p + size)});
}

void Aside::flush()
{
    worker_.flush();
}

int64_t Aside::published() const
{
    return published_;
}

int64_t Aside::failed() const
{
    return failed_;
}

int64_t Aside::waits() const
{
    return worker_.counts().waits;
}

nlohmann::json Aside::report() const
{
    return {{"published", published()}, {"failed", failed()}, {"waits", waits()}};
}

void Aside::publish(std::vector<Msg> &batch)
{
    int64_t ok = 0, bad = 0;
    for (const auto &m : batch) {
        if (publish_raw(*lc_, m.channel, m.data.data(), m.data.size()) == 0) ++ok;
        else ++bad;
    }
    published_ += ok;
    failed_ += bad;
}

}  // namespace afm
