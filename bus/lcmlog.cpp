#include "lcmlog.hpp"

#include "big_endian.hpp"

#include <cstdio>
#include <cstring>

namespace afm {

LogReader::LogReader(std::string path) : path_(std::move(path)), f_(path_, std::ios::binary)
{
    if (!f_) throw LogError(path_ + ": cannot open (" + std::strerror(errno) + ")");
}

std::string LogReader::where(uint64_t at) const { return path_ + ": byte offset " + std::to_string(at); }

uint64_t LogReader::refresh_size()
{
    f_.clear();
    const std::streampos here = f_.tellg();
    f_.seekg(0, std::ios::end);
    size_ = static_cast<uint64_t>(f_.tellg());
    f_.seekg(here);
    return size_;
}

bool LogReader::have(uint64_t bytes)
{
    // the size is read again only when the event seems to end past it (a
    // growing file); a finished file is measured once
    return size_ - off_ >= bytes || (refresh_size() > off_ && size_ - off_ >= bytes);
}

bool LogReader::wanted(const char *ch, uint32_t len) const
{
    if (only_.empty()) return true;
    for (const auto &c : only_)
        if (c.size() == len && std::memcmp(c.data(), ch, len) == 0) return true;
    return false;
}

LogReader::Next LogReader::next(LogEvent *ev)
{
    for (;;) {
        const Next n = next_framed(ev);
        if (n != Next::kEvent) return n;
        ++events_;
        if (!ev->data.empty() || wanted(ev->channel.data(), static_cast<uint32_t>(ev->channel.size()))) return n;
    }
}

LogReader::Next LogReader::next_framed(LogEvent *ev)
{
    if (off_ >= size_ && refresh_size() <= off_) return Next::kEnd;
    if (!have(kHeaderBytes)) return Next::kIncomplete;
    unsigned char h[kHeaderBytes];
    if (!at_off_) {
        f_.clear();
        f_.seekg(static_cast<std::streamoff>(off_));
    }
    at_off_ = false;   // until the whole event is read
    if (!f_.read(reinterpret_cast<char *>(h), kHeaderBytes)) return Next::kIncomplete;
    if (be32(h) != kSync)
        throw LogError(where(off_) + ": corrupt log: no event starts here (sync word 0x" + [&] {
            char b[9];
            std::snprintf(b, sizeof b, "%08x", be32(h));
            return std::string(b);
        }() + ", expected 0xeda1da01)");
    const uint32_t clen = be32(h + 20), dlen = be32(h + 24);
    if (clen == 0 || clen > kMaxChannelBytes)
        throw LogError(where(off_) + ": corrupt log: channel length " + std::to_string(clen) + " (1.." +
                       std::to_string(kMaxChannelBytes) + ")");
    if (dlen > kMaxDataBytes)
        throw LogError(where(off_) + ": corrupt log: data length " + std::to_string(dlen) + " beyond the limit of " +
                       std::to_string(kMaxDataBytes) + " bytes");
    if (!have(uint64_t(kHeaderBytes) + clen + dlen)) return Next::kIncomplete;
    ev->offset = off_;
    ev->number = static_cast<int64_t>(be64(h + 4));
    ev->utime = static_cast<int64_t>(be64(h + 12));
    ev->channel.assign(clen, '\0');
    if (!f_.read(ev->channel.data(), clen)) return Next::kIncomplete;
    if (wanted(ev->channel.data(), clen)) {
        ev->data.resize(dlen);
        if (!f_.read(reinterpret_cast<char *>(ev->data.data()), dlen)) return Next::kIncomplete;
    } else {
        ev->data.clear();   // passed over: framed and checked, not kept
        // through the stream's buffer, not a seek: a seek is a system call
        // and a refill per event, and most of a log's events are passed over
        if (!f_.ignore(dlen) || f_.gcount() != static_cast<std::streamsize>(dlen)) return Next::kIncomplete;
    }
    off_ += uint64_t(kHeaderBytes) + clen + dlen;
    at_off_ = true;
    return Next::kEvent;
}

bool LogReader::read(LogEvent *ev)
{
    switch (next(ev)) {
    case Next::kEvent: return true;
    case Next::kEnd: return false;
    case Next::kIncomplete: break;
    }
    // off_ stands at the start of the event the file cuts (skipped events
    // before it were read whole)
    throw LogError(where(off_) + ": truncated log: the file ends at byte " + std::to_string(refresh_size()) +
                   ", inside the event that starts here");
}

LogWriter::LogWriter(const std::string &path) : path_(path)
{
    errno = 0;
    log_ = lcm_eventlog_create(path.c_str(), "w");
    if (!log_) throw LogError(path + ": cannot create the log (" + std::strerror(errno ? errno : EIO) + ")");
}

LogWriter::~LogWriter()
{
    if (log_) lcm_eventlog_destroy(log_);
}

void LogWriter::write(int64_t utime, const std::string &channel, const void *data, std::size_t size)
{
    lcm_eventlog_event_t ev{};
    ev.eventnum = n_;
    ev.timestamp = utime;
    ev.channellen = static_cast<int32_t>(channel.size());
    ev.datalen = static_cast<int32_t>(size);
    ev.channel = const_cast<char *>(channel.c_str());
    ev.data = const_cast<void *>(data);
    errno = 0;
    if (lcm_eventlog_write_event(log_, &ev) != 0)
        throw LogError(path_ + ": cannot write event " + std::to_string(n_) + " after " + std::to_string(bytes_) + " bytes (" +
                       std::strerror(errno ? errno : EIO) + ")");
    ++n_;
    bytes_ += LogReader::kHeaderBytes + static_cast<int64_t>(channel.size()) + static_cast<int64_t>(size);
}

void LogWriter::flush()
{
    errno = 0;
    if (std::fflush(log_->f) != 0 || std::ferror(log_->f))
        throw LogError(path_ + ": cannot write, " + std::to_string(bytes_) + " bytes given to it (" +
                       std::strerror(errno ? errno : EIO) + ")");
}

}  // namespace afm
