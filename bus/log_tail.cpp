#include "log_tail.hpp"

#include <algorithm>
#include <filesystem>

#include "afm/analog_block_t.hpp"
#include "afm/haptic_pose_t.hpp"
#include "afm/scan_line_t.hpp"
#include "afm/tip_cmd_t.hpp"
#include "afm_channels.h"
#include "inbox.hpp"

namespace afm {

void LogTail::poll(int64_t published)
{
    if (!reader_) {
        if (!std::filesystem::exists(path_)) return;
        reader_ = std::make_unique<LogReader>(path_);
        // the other channels' events are framed and passed over, their
        // bytes never copied (most of a block's bytes: SIM_TRUTH, FW_STATE)
        reader_->only({AFM_CH_AFM_ANALOG, AFM_CH_HAPTIC_POSE, AFM_CH_AFM_CMD, AFM_CH_AFM_SCAN_LINE});
    }
    LogEvent ev;
    while (reader_->next(&ev) == LogReader::Next::kEvent) {
        if (ev.channel == AFM_CH_AFM_ANALOG) {
            analog_block_t b;
            if (decode_checked(ev.data.data(), ev.data.size(), &b) == Reject::none && b.seq <= published)
                last_seq_ = std::max(last_seq_, b.seq);
        } else if (ev.channel == AFM_CH_HAPTIC_POSE) {
            haptic_pose_t p;   // the pose for the block after the last published may be recorded already
            if (decode_checked(ev.data.data(), ev.data.size(), &p) == Reject::none && p.seq <= published + 1)
                last_pose_seq_ = std::max(last_pose_seq_, p.seq);
        } else if (ev.channel == AFM_CH_AFM_CMD) {
            tip_cmd_t c{};
            if (decode_checked(ev.data.data(), ev.data.size(), &c) == Reject::none && c.ack_seq <= published)
                last_cmd_seq_ = std::max(last_cmd_seq_, c.ack_seq);
        } else if (ev.channel == AFM_CH_AFM_SCAN_LINE) {
            scan_line_t l;
            if (decode_checked(ev.data.data(), ev.data.size(), &l) == Reject::none) ++scan_lines_;
        }
    }
}

}  // namespace afm
