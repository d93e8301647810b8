#include "lcmlog.hpp"

#include <cstdio>
#include <cstring>

namespace afm {

namespace {
uint32_t be32(const unsigned char *p)
{
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}
uint64_t be64(const unsigned char *p) { return (uint64_t(be32(p)) << 32) | be32(p + 4); }
}  // namespace

LogReader::LogReader(std::string path) : path_(std::move(path)), f_(path_, std::ios::binary)
{
    if (!f_) throw LogError(path_ + ": cannot open (" + std::strerror(errno) + ")");
}

std::string LogReader::where(uint64_t at) const { return path_ + ": byte offset " + std::to_string(at); }

LogReader::Next LogReader::next(LogEvent *ev)
{
    f_.clear();
    f_.seekg(0, std::ios::end);
    const uint64_t size = static_cast<uint64_t>(f_.tellg());
    if (size <= off_) return Next::kEnd;
    if (size - off_ < kHeaderBytes) return Next::kIncomplete;
    unsigned char h[kHeaderBytes];
    f_.seekg(static_cast<std::streamoff>(off_));
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
    if (size - off_ < uint64_t(kHeaderBytes) + clen + dlen) return Next::kIncomplete;
    ev->offset = off_;
    ev->number = static_cast<int64_t>(be64(h + 4));
    ev->utime = static_cast<int64_t>(be64(h + 12));
    ev->channel.assign(clen, '\0');
    ev->data.resize(dlen);
    if (!f_.read(ev->channel.data(), clen) || !f_.read(reinterpret_cast<char *>(ev->data.data()), dlen))
        return Next::kIncomplete;
    off_ += uint64_t(kHeaderBytes) + clen + dlen;
    return Next::kEvent;
}

bool LogReader::read(LogEvent *ev)
{
    const uint64_t at = off_;
    switch (next(ev)) {
    case Next::kEvent: return true;
    case Next::kEnd: return false;
    case Next::kIncomplete: break;
    }
    f_.clear();
    f_.seekg(0, std::ios::end);
    throw LogError(where(at) + ": truncated log: the file ends at byte " + std::to_string(static_cast<uint64_t>(f_.tellg())) +
                   ", inside the event that starts here");
}

}  // namespace afm
