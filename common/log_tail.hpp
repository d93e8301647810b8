// Follows an LCM log file as lcm-logger writes it, to know what is safely
// recorded: the last analog block and the number of scan lines. The
// simulator stays within a few messages of it, because lcm-logger drops
// messages once 30 wait in its subscription queue (a CPU-starved logger):
// with the window, a busy machine slows the run down instead.
//
// LCM log format, per event: sync word 0xEDA1DA01, int64 event number, int64
// timestamp, int32 channel length, int32 data length (big-endian), channel,
// data. analog_block_t data: 8-byte fingerprint, int64 utime, int64 seq.
#pragma once

#include <cstdint>
#include <fstream>
#include <string>

namespace afm {

class LogTail {
public:
    explicit LogTail(std::string path) : path_(std::move(path)) {}
    // Reads the events appended since the last call.
    void poll();
    int64_t last_analog_seq() const { return last_seq_; }
    int64_t scan_lines() const { return scan_lines_; }

private:
    std::string path_;
    std::ifstream f_;
    std::streamoff off_ = 0;
    int64_t last_seq_ = -1;
    int64_t scan_lines_ = 0;
};

}  // namespace afm
