#include "log_tail.hpp"

#include <algorithm>
#include <filesystem>

#include "afm/analog_block_t.hpp"
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
        } else if (ev.channel == AFM_CH_AFM_SCAN_LINE) {
            ++scan_lines_;
        }
    }
}

}  // namespace afm
