#include "log_tail.hpp"

#include <algorithm>
#include <filesystem>

#include "afm/analog_block_t.hpp"
#include "afm/haptic_pose_t.hpp"
#include "afm/tip_cmd_t.hpp"
#include "afm_channels.h"

namespace afm {

void LogTail::poll()
{
    if (!reader_) {
        if (!std::filesystem::exists(path_)) return;
        reader_ = std::make_unique<LogReader>(path_);
    }
    LogEvent ev;
    while (reader_->next(&ev) == LogReader::Next::kEvent) {
        if (ev.channel == AFM_CH_AFM_ANALOG) {
            analog_block_t b;
            if (b.decode(ev.data.data(), 0, static_cast<int>(ev.data.size())) >= 0) last_seq_ = std::max(last_seq_, b.seq);
        } else if (ev.channel == AFM_CH_HAPTIC_POSE) {
            haptic_pose_t p;
            if (p.decode(ev.data.data(), 0, static_cast<int>(ev.data.size())) >= 0) last_pose_seq_ = std::max(last_pose_seq_, p.seq);
        } else if (ev.channel == AFM_CH_AFM_CMD) {
            tip_cmd_t c;
            if (c.decode(ev.data.data(), 0, static_cast<int>(ev.data.size())) >= 0) last_cmd_seq_ = std::max(last_cmd_seq_, c.ack_seq);
        } else if (ev.channel == AFM_CH_AFM_SCAN_LINE) {
            ++scan_lines_;
        }
    }
}

}  // namespace afm
