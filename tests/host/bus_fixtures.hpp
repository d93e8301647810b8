// The bus tests' shared fixtures (test_bus_tap.cpp, test_bus_inbox.cpp): a
// test payload, a raw socket that sends on the run's loopback alone, and the
// check that a test runs in a private network namespace. Include it after
// the project's headers (unity.h's isnan macro breaks nlohmann/json).
#pragma once

#include <unity.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <cstdio>
#include <string>
#include <vector>

#include "bus.hpp"

namespace bus_fixtures {

// n bytes of a pattern that differs by seed.
inline std::vector<unsigned char> pattern(std::size_t n, unsigned seed)
{
    std::vector<unsigned char> v(n);
    for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<unsigned char>((i * 131u + seed * 7u) >> 3);
    return v;
}

// A UDP socket whose multicast stays on this namespace's loopback (TTL 0).
inline int open_raw()
{
    const int raw = socket(AF_INET, SOCK_DGRAM, 0);
    const unsigned char ttl = 0;
    setsockopt(raw, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, 1);
    return raw;
}

// Sends datagram d to the bus's group and port, as any sender may.
inline void send_raw(int raw, const std::vector<unsigned char> &d)
{
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<uint16_t>(afm::kBusPort));
    inet_pton(AF_INET, "239.255.76.67", &to.sin_addr);
    TEST_ASSERT_EQUAL_INT(static_cast<int>(d.size()), sendto(raw, d.data(), d.size(), 0, reinterpret_cast<sockaddr *>(&to), sizeof to));
}

// True inside a private network namespace (run/in_netns.sh, from ctest);
// else says so, naming the program.
inline bool in_run(const char *program)
{
    std::string why;
    if (afm::multicast_stays_in_run(&why)) return true;
    std::fprintf(stderr, "%s: run me inside run/in_netns.sh (%s)\n", program, why.c_str());
    return false;
}

}  // namespace bus_fixtures
