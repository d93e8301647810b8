// Follows an LCM log file as lcm-logger writes it, to know what is safely
// recorded: the last block of the card's inputs and answer (AFM_ANALOG,
// HAPTIC_POSE, AFM_CMD) and the number of scan lines. The
// simulator stays within a few messages of it, because lcm-logger drops
// messages once 30 wait in its subscription queue (a CPU-starved logger):
// with the window, a busy machine slows the run down instead.
//
// The log is read with LogReader (lcmlog.hpp), each message through the
// bus's decode-and-check (inbox.hpp). The log holds whatever was on the
// bus, hostile datagrams too: a block number is taken only up to the last
// block the simulator itself has published (poll's argument), so that a
// message from the far future cannot open the window.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>

#include "lcmlog.hpp"

namespace afm {

class LogTail {
public:
    explicit LogTail(std::string path) : path_(std::move(path)) {}
    // Reads the events appended since the last call (a file not yet there
    // is no event yet; a corrupt one throws LogError). published: the last
    // analog block the simulator has published; an analog block, pose or
    // command with a later block number is not the run's and is skipped.
    void poll(int64_t published);
    int64_t last_analog_seq() const { return last_seq_; }
    // The last block whose analog block, pose and command are all recorded.
    int64_t last_block_recorded() const { return std::min(last_seq_, std::min(last_pose_seq_, last_cmd_seq_)); }
    int64_t scan_lines() const { return scan_lines_; }

private:
    std::string path_;
    std::unique_ptr<LogReader> reader_;
    int64_t last_seq_ = -1;
    int64_t last_pose_seq_ = -1;
    int64_t last_cmd_seq_ = -1;
    int64_t scan_lines_ = 0;
};

}  // namespace afm
