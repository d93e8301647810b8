#include "log_tail.hpp"

#include <algorithm>

#include "afm_channels.h"

namespace afm {

namespace {
constexpr std::streamoff kHeader = 28;
constexpr uint32_t kSync = 0xEDA1DA01u;
uint32_t be32(const unsigned char *p) { return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3]; }
}  // namespace

void LogTail::poll()
{
    if (!f_.is_open()) {
        f_.open(path_, std::ios::binary);
        if (!f_.is_open()) return;
    }
    f_.clear();
    f_.seekg(0, std::ios::end);
    const std::streamoff size = f_.tellg();
    while (size - off_ >= kHeader) {
        unsigned char h[kHeader];
        f_.seekg(off_);
        if (!f_.read(reinterpret_cast<char *>(h), kHeader) || be32(h) != kSync) return;
        const uint32_t clen = be32(h + 20), dlen = be32(h + 24);
        if (size - off_ < kHeader + clen + dlen) return;   // the event is not complete yet
        std::string ch(clen, '\0');
        f_.read(ch.data(), clen);
        if (ch == AFM_CH_AFM_ANALOG && dlen >= 24) {
            unsigned char d[24];
            f_.read(reinterpret_cast<char *>(d), 24);
            const uint64_t seq = (uint64_t(be32(d + 16)) << 32) | be32(d + 20);
            last_seq_ = std::max(last_seq_, static_cast<int64_t>(seq));
        } else if (ch == AFM_CH_AFM_SCAN_LINE) {
            ++scan_lines_;
        }
        off_ += kHeader + clen + dlen;
    }
}

}  // namespace afm
