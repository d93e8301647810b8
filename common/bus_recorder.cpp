#include "bus_recorder.hpp"

#include "bus.hpp"
#include "bus_filter.hpp"

namespace afm {

BusRecorder::BusRecorder(lcm::LCM &lc, const std::string &path) : lc_(lc), log_(path)
{
    sub_ = lc_.subscribe(".*", &BusRecorder::on, this);
    bus_filter_off();   // every channel: no kernel filter in this process
    sub_->setQueueCapacity(kQueueCapacity);
}

BusRecorder::~BusRecorder()
{
    if (sub_) lc_.unsubscribe(sub_);
}

void BusRecorder::on(const lcm::ReceiveBuffer *rb, const std::string &channel)
{
    if (!error_.empty()) return;   // the file is broken: the run is failing already
    try {
        log_.write(rb->recv_utime, channel, rb->data, rb->data_size);
    } catch (const LogError &e) {
        error_ = e.what();   // not thrown through LCM's C dispatch
    }
}

int BusRecorder::drain(bool bus_quiet, int max)
{
    int n = 0;
    while (n < max && error_.empty() && lc_.handleTimeout(0) > 0) ++n;
    if (!error_.empty()) throw LogError(error_);
    if (unflushed() && (bus_quiet || log_.bytes() - flushed_ >= kFlushBytes)) {
        log_.flush();
        flushed_ = log_.bytes();
    }
    return n;
}

}  // namespace afm
