// Big-endian reads of the bus's wire formats: LCM's UDP datagrams
// (bus_filter.hpp) and LCM log files (lcmlog.hpp). p must hold the 4 or 8
// bytes read; the callers check their lengths first.
#pragma once

#include <cstdint>

namespace afm {

inline uint32_t be32(const unsigned char *p)
{
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | uint32_t(p[3]);
}

inline uint64_t be64(const unsigned char *p) { return (uint64_t(be32(p)) << 32) | be32(p + 4); }

}  // namespace afm
