#include "bus_recorder.hpp"

#include "text.hpp"

namespace afm {

nlohmann::json channels_json(const std::map<std::string, int64_t> &counts)
{
    nlohmann::json j = nlohmann::json::object();
    for (const auto &[channel, n] : counts) j[printable(channel)] = n;
    return j;
}

BusRecorder::BusRecorder(const std::string &path) : log_(path) {}

void BusRecorder::take(const std::string &channel, const unsigned char *data, std::size_t size, int64_t recv_utime)
{
    log_.write(recv_utime, channel, data, size);
}

void BusRecorder::settle(bool bus_quiet)
{
    if (unflushed() && (bus_quiet || log_.bytes() - flushed_ >= kFlushBytes)) {
        log_.flush();
        flushed_ = log_.bytes();
    }
}

}  // namespace afm
