// Follows the run's LCM log file as the launcher's recorder writes it
// (bus_recorder.hpp), to know what is safely recorded: the last block of the
// card's inputs and answer (AFM_ANALOG, HAPTIC_POSE, AFM_CMD) and the number
// of scan lines. The simulator stays within a window of it, because a
// recorder starved of CPU loses datagrams once its socket's receive buffer
// fills: with the window, a busy machine slows the run down instead.
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

// The window the simulator keeps ahead of the record, in analog blocks:
// as many blocks as the recorder's socket can hold while it sleeps between
// batches, at kLogBytesPerBlock of its receive buffer each, from
// kLogWindowMin to kLogWindowMax. The receive buffer is the kernel's figure
// for the recorder's socket (SO_RCVBUF: twice the request, capped by
// net.core.rmem_max), in the kernel's accounting of a datagram (its
// buffer, not its payload: about 830 bytes for a small message, 2.3 kB for
// the default scene's 836-byte analog block). A default-scene block takes
// about 10 kB of it, a 100-particle scene's about 30 kB: 32 kB a block
// leaves room. Wider than 8 blocks, the recorder's 0.5 ms sleep no longer
// stops the simulator (./afm bench bus, "log waits"); past 64 it would
// gain nothing. Scan lines keep their own window (16 lines).
constexpr int64_t kLogBytesPerBlock = 32 * 1024;
constexpr int64_t kLogWindowMin = 8, kLogWindowMax = 64;
constexpr int64_t log_window_blocks(int64_t receive_buffer_bytes)
{
    const int64_t n = receive_buffer_bytes / kLogBytesPerBlock;
    return n < kLogWindowMin ? kLogWindowMin : n > kLogWindowMax ? kLogWindowMax : n;
}

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
