// The bench's one reader of LCM log files (lcm-logger's format), for the
// launcher's record count, the simulator's log window (LogTail) and replay.
//
// Per event, big-endian: sync word 0xEDA1DA01, int64 event number, int64
// timestamp (us), int32 channel length, int32 data length, the channel,
// the data. A reader knows where every event starts (its byte offset), so
// an error names the file and the offset.
//
// Limits: a channel name of at most kMaxChannelBytes, data of at most
// kMaxDataBytes (the bench's largest message, a scan line or the objects
// with a full trench store, is well below 1 MiB); anything longer is a
// corrupt event, never an allocation.
#pragma once

#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>
#include <lcm/eventlog.h>

namespace afm {

class LogError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct LogEvent {
    uint64_t offset = 0;          // byte offset of the event's sync word
    int64_t number = 0;           // lcm-logger's event number
    int64_t utime = 0;            // wall-clock time it was logged, us
    std::string channel;
    std::vector<uint8_t> data;
};

class LogReader {
public:
    static constexpr uint32_t kSync = 0xEDA1DA01u;
    static constexpr uint32_t kHeaderBytes = 28;
    static constexpr uint32_t kMaxChannelBytes = 1024;
    static constexpr uint32_t kMaxDataBytes = 16u << 20;

    enum class Next {
        kEvent,        // *ev holds the next event
        kEnd,          // the file ends where an event would start
        kIncomplete    // the file ends inside an event (truncated, or still being written)
    };

    // Opens path; throws LogError naming it when it cannot.
    explicit LogReader(std::string path);
    // The next event from offset(). On kIncomplete the offset stays at the
    // event's start, so a reader that follows a growing file calls again
    // later. Throws LogError naming the file and the byte offset for a
    // corrupt event (no sync word, a length beyond the limits).
    Next next(LogEvent *ev);
    // next() for a finished file: an event, or false at the end; a file
    // that ends inside an event is truncated: LogError with the offset.
    bool read(LogEvent *ev);
    // Only these channels are returned; the others' events are framed and
    // checked but their data is not read (empty: every channel).
    void only(std::vector<std::string> channels) { only_ = std::move(channels); }
    // Events passed over, framed, since opening (returned or skipped).
    int64_t events() const { return events_; }
    uint64_t offset() const { return off_; }
    const std::string &path() const { return path_; }

private:
    std::string path_;
    std::ifstream f_;
    uint64_t off_ = 0;
    uint64_t size_ = 0;       // the file's size when last measured
    bool at_off_ = false;     // the stream stands at off_ (no seek needed)
    std::vector<std::string> only_;
    int64_t events_ = 0;
    bool wanted(const char *ch, uint32_t len) const;
    std::string where(uint64_t at) const;
    uint64_t refresh_size();
    Next next_framed(LogEvent *ev);
    bool have(uint64_t bytes);
};

// Writes an LCM event log (LCM's own format and writer, lcm_eventlog_*), as
// lcm-logger does: the run's recorder (bus_recorder.hpp) and replay --write.
// A write that fails (a full disk) throws LogError naming the file and the
// system's reason; so does flush(). Not copyable.
class LogWriter {
public:
    explicit LogWriter(const std::string &path);   // "w": an existing file is replaced
    ~LogWriter();
    LogWriter(const LogWriter &) = delete;
    LogWriter &operator=(const LogWriter &) = delete;
    void write(int64_t utime, const std::string &channel, const void *data, std::size_t size);
    void flush();   // to the kernel (fflush): a LogTail then reads everything written
    int64_t events() const { return n_; }
    int64_t bytes() const { return bytes_; }   // the log's size once flushed: headers (LogReader::kHeaderBytes), channels, data

private:
    std::string path_;
    lcm_eventlog_t *log_ = nullptr;
    int64_t n_ = 0;
    int64_t bytes_ = 0;
};

}  // namespace afm
