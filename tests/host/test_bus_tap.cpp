// Unity tests of the bus's receiver (bus/bus_tap), the launcher's tap and
// every inbox's reader: what liblcm publishes, short or in fragments, from
// one sender or two at once, comes out whole and in order, as a
// subscription to ".*" would see it; and what liblcm itself would drop
// (garbage, a fragment without its fragment 0, a fragment past its message)
// is dropped and counted, a repeated fragment taken once, an unfinished
// message abandoned when its sender moves on; a message at a time (next) as
// liblcm's handleTimeout hands them; a filtered receiver sees only its
// channels; the record's window follows the receive buffer; a URL it cannot
// use is refused. The inbox on the bus: test_bus_inbox.cpp.
// Runs inside a private network namespace (run/in_netns.sh, from ctest):
// the bus is real udpm multicast on its loopback.
#include "bus.hpp"   // the project's headers before unity.h, whose isnan macro breaks nlohmann/json
#include "bus_filter.hpp"
#include "bus_tap.hpp"
#include "log_tail.hpp"

#include "bus_fixtures.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <memory>
#include <pthread.h>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

using bus_fixtures::pattern;

namespace {

struct Got {
    std::string channel;
    std::vector<unsigned char> data;
    int64_t utime;
};

std::unique_ptr<afm::BusTap> tap;
std::unique_ptr<lcm::LCM> pub;
int raw = -1;

// Everything the tap holds once `want` messages have come (or 2 s passed).
std::vector<Got> take(std::size_t want, int max = 100000)
{
    std::vector<Got> got;
    for (int i = 0; i < 200 && got.size() < want; ++i) {
        if (!tap->wait(10)) continue;
        tap->drain([&](const std::string &c, const unsigned char *d, std::size_t n, int64_t t) { got.push_back({c, {d, d + n}, t}); }, max);
    }
    // and anything more that came with them
    usleep(20000);
    tap->drain([&](const std::string &c, const unsigned char *d, std::size_t n, int64_t t) { got.push_back({c, {d, d + n}, t}); }, max);
    return got;
}

void be32(std::vector<unsigned char> *v, uint32_t x)
{
    for (int s = 24; s >= 0; s -= 8) v->push_back(static_cast<unsigned char>(x >> s));
}

// An LCM fragment as liblcm lays one out (bus_filter.hpp's header).
std::vector<unsigned char> fragment(uint32_t seq, uint32_t size, uint32_t offset, uint16_t no, uint16_t count, const std::string &channel,
                                    const std::vector<unsigned char> &payload)
{
    std::vector<unsigned char> d;
    be32(&d, afm::kLcmFragmentMagic);
    be32(&d, seq);
    be32(&d, size);
    be32(&d, offset);
    d.push_back(static_cast<unsigned char>(no >> 8));
    d.push_back(static_cast<unsigned char>(no));
    d.push_back(static_cast<unsigned char>(count >> 8));
    d.push_back(static_cast<unsigned char>(count));
    if (no == 0) d.insert(d.end(), channel.c_str(), channel.c_str() + channel.size() + 1);
    d.insert(d.end(), payload.begin(), payload.end());
    return d;
}

void send_raw(const std::vector<unsigned char> &d) { bus_fixtures::send_raw(raw, d); }

}  // namespace

void setUp()
{
    tap->drain([](const std::string &, const unsigned char *, std::size_t, int64_t) {});   // nothing left from the last test
}
void tearDown() {}

void test_short_messages_come_whole_in_order_with_their_time()
{
    const int64_t t0 = afm::wall_utime();
    const auto a = pattern(49, 1), b = pattern(836, 2), c = pattern(0, 3);
    pub->publish("AFM_CMD", a.data(), static_cast<unsigned>(a.size()));
    pub->publish("AFM_ANALOG", b.data(), static_cast<unsigned>(b.size()));
    pub->publish("X", c.data(), 0);
    const auto got = take(3);
    const int64_t t1 = afm::wall_utime();
    TEST_ASSERT_EQUAL_INT(3, static_cast<int>(got.size()));
    TEST_ASSERT_EQUAL_STRING("AFM_CMD", got[0].channel.c_str());
    TEST_ASSERT_TRUE(got[0].data == a);
    TEST_ASSERT_EQUAL_STRING("AFM_ANALOG", got[1].channel.c_str());
    TEST_ASSERT_TRUE(got[1].data == b);
    TEST_ASSERT_EQUAL_STRING("X", got[2].channel.c_str());
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(got[2].data.size()));
    for (const auto &g : got) TEST_ASSERT_TRUE(g.utime >= t0 - 1000 && g.utime <= t1 + 1000);
    TEST_ASSERT_TRUE(got[0].utime <= got[1].utime && got[1].utime <= got[2].utime);
}

// liblcm sends a message over its short-message size in fragments.
void test_a_fragmented_message_comes_whole()
{
    const auto big = pattern(300000, 4);
    pub->publish("AFM_SCAN_LINE", big.data(), static_cast<unsigned>(big.size()));
    const auto got = take(1);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(got.size()));
    TEST_ASSERT_EQUAL_STRING("AFM_SCAN_LINE", got[0].channel.c_str());
    TEST_ASSERT_EQUAL_INT(static_cast<int>(big.size()), static_cast<int>(got[0].data.size()));
    TEST_ASSERT_TRUE(got[0].data == big);
}

// Two senders' fragments interleave on the bus: each message is gathered
// per sender.
void test_two_senders_fragments_interleaved_each_come_whole()
{
    const auto a = pattern(100000, 5), b = pattern(90000, 6);
    std::vector<std::vector<unsigned char>> fa, fb;
    const std::size_t step = 60000;
    for (uint16_t k = 0; k * step < a.size(); ++k) {
        const std::size_t at = k * step, n = std::min(step, a.size() - at);
        fa.push_back(fragment(77, static_cast<uint32_t>(a.size()), static_cast<uint32_t>(at), k, 2, "A",
                              std::vector<unsigned char>(a.begin() + static_cast<long>(at), a.begin() + static_cast<long>(at + n))));
    }
    for (uint16_t k = 0; k * step < b.size(); ++k) {
        const std::size_t at = k * step, n = std::min(step, b.size() - at);
        fb.push_back(fragment(77, static_cast<uint32_t>(b.size()), static_cast<uint32_t>(at), k, 2, "B",
                              std::vector<unsigned char>(b.begin() + static_cast<long>(at), b.begin() + static_cast<long>(at + n))));
    }
    // a second sender: a socket of its own (another port)
    const int other = socket(AF_INET, SOCK_DGRAM, 0);
    const unsigned char ttl = 0;
    setsockopt(other, IPPROTO_IP, IP_MULTICAST_TTL, &ttl, 1);
    sockaddr_in to{};
    to.sin_family = AF_INET;
    to.sin_port = htons(static_cast<uint16_t>(afm::kBusPort));
    inet_pton(AF_INET, "239.255.76.67", &to.sin_addr);
    send_raw(fa[0]);
    sendto(other, fb[0].data(), fb[0].size(), 0, reinterpret_cast<sockaddr *>(&to), sizeof to);
    send_raw(fa[1]);
    sendto(other, fb[1].data(), fb[1].size(), 0, reinterpret_cast<sockaddr *>(&to), sizeof to);
    close(other);
    const auto got = take(2);
    TEST_ASSERT_EQUAL_INT(2, static_cast<int>(got.size()));
    TEST_ASSERT_EQUAL_STRING("A", got[0].channel.c_str());
    TEST_ASSERT_TRUE(got[0].data == a);
    TEST_ASSERT_EQUAL_STRING("B", got[1].channel.c_str());
    TEST_ASSERT_TRUE(got[1].data == b);
}

void test_a_repeated_fragment_is_taken_once()
{
    const auto a = pattern(20, 7);
    const auto f0 = fragment(9, 20, 0, 0, 2, "DUP", {a.begin(), a.begin() + 10});
    const auto f1 = fragment(9, 20, 10, 1, 2, "DUP", {a.begin() + 10, a.end()});
    send_raw(f0);
    send_raw(f0);
    send_raw(f1);
    send_raw(f1);
    const auto got = take(1);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(got.size()));
    TEST_ASSERT_TRUE(got[0].data == a);
}

// What liblcm would drop, the tap drops and counts; nothing is delivered.
void test_what_lcm_would_drop_is_dropped_and_counted()
{
    const int64_t before = tap->dropped();
    const auto p = pattern(10, 8);
    send_raw({'h', 'e', 'l', 'l', 'o', ' ', 'b', 'u', 's'});               // garbage
    send_raw({'L', 'C'});                                                  // shorter than a magic
    send_raw(fragment(20, 20, 10, 1, 2, "", p));                            // no fragment 0 before it
    send_raw(fragment(21, 20, 15, 0, 2, "LATE", p));                        // past its message's size
    send_raw(fragment(22, 20, 0, 2, 2, "NUMBER", p));                      // number not below its count
    std::vector<unsigned char> noname = {'L', 'C', '0', '2', 0, 0, 0, 1, 'A', 'B'};   // a name without its NUL
    send_raw(noname);
    // a name over liblcm's 63 bytes (the run's log could not hold one of 1100)
    std::vector<unsigned char> longname = {'L', 'C', '0', '2', 0, 0, 0, 2};
    longname.insert(longname.end(), 64, 'N');
    longname.push_back(0);
    send_raw(longname);
    send_raw(fragment(23, (16u << 20) + 1, 0, 0, 300, "HUGE", p));          // over what the log holds
    send_raw(fragment(24, 200000, 0, 0, 2, "NOROOM", p));                  // more than 2 fragments can carry
    const auto got = take(0);
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(got.size()));
    TEST_ASSERT_EQUAL_INT(9, static_cast<int>(tap->dropped() - before));
}

// A fragment lost: the sender's next message abandons the unfinished one,
// and comes whole itself.
void test_a_new_message_abandons_an_unfinished_one()
{
    const auto a = pattern(20, 9);
    // first a whole message from this sender (whatever it left unfinished before is abandoned here)
    send_raw(fragment(29, 20, 0, 0, 2, "CLEAN", {a.begin(), a.begin() + 10}));
    send_raw(fragment(29, 20, 10, 1, 2, "CLEAN", {a.begin() + 10, a.end()}));
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(take(1).size()));
    const int64_t before = tap->abandoned();
    send_raw(fragment(30, 20, 0, 0, 2, "LOST", {a.begin(), a.begin() + 10}));   // its fragment 1 never comes
    send_raw(fragment(31, 20, 0, 0, 2, "NEXT", {a.begin(), a.begin() + 10}));
    send_raw(fragment(31, 20, 10, 1, 2, "NEXT", {a.begin() + 10, a.end()}));
    const auto got = take(1);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(got.size()));
    TEST_ASSERT_EQUAL_STRING("NEXT", got[0].channel.c_str());
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(tap->abandoned() - before));
}

// Fragment 0 headers that claim 16 MiB each (40-odd bytes a datagram): the
// tap holds what arrived, not what was claimed; its peak memory does not
// grow by the claims.
void test_claimed_sizes_cost_no_memory_until_the_fragments_come()
{
    struct rusage r0 {};
    getrusage(RUSAGE_SELF, &r0);
    const auto p = pattern(10, 11);
    const int64_t abandoned0 = tap->abandoned();
    for (uint32_t i = 0; i < 400; ++i) {
        send_raw(fragment(1000 + i, 16u << 20, 0, 0, 300, "CLAIM", p));
        if (i % 50 == 49) take(0);   // the tap reads them as the bus delivers them
    }
    take(0);
    struct rusage r1 {};
    getrusage(RUSAGE_SELF, &r1);
    std::printf("400 headers claiming 16 MiB: held %zu bytes, peak RSS %ld -> %ld kB, %lld abandoned\n", tap->held_bytes(),
                r0.ru_maxrss, r1.ru_maxrss, static_cast<long long>(tap->abandoned() - abandoned0));
    TEST_ASSERT_TRUE(tap->held_bytes() <= afm::BusTap::kMaxPartial * 1500);
    TEST_ASSERT_TRUE(r1.ru_maxrss - r0.ru_maxrss < 20 * 1024);   // < 20 MB (one claim is 16 MiB)
    TEST_ASSERT_TRUE(tap->abandoned() - abandoned0 >= 399);       // each new one abandons the last (one sender)
    // and a real fragmented message still comes whole after the flood
    const auto a = pattern(3000, 12);
    send_raw(fragment(5000, 3000, 0, 0, 2, "AFTER", {a.begin(), a.begin() + 1500}));
    send_raw(fragment(5000, 3000, 1500, 1, 2, "AFTER", {a.begin() + 1500, a.end()}));
    const auto got = take(1);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(got.size()));
    TEST_ASSERT_TRUE(got[0].data == a);
}

// drain(max) reads at most max datagrams; the rest wait for the next drain.
void test_drain_takes_at_most_max_datagrams()
{
    const auto a = pattern(8, 10);
    for (int i = 0; i < 5; ++i) pub->publish("MANY", a.data(), static_cast<unsigned>(a.size()));
    usleep(20000);
    std::vector<Got> got;
    auto sink = [&](const std::string &c, const unsigned char *d, std::size_t n, int64_t t) { got.push_back({c, {d, d + n}, t}); };
    TEST_ASSERT_EQUAL_INT(2, tap->drain(sink, 2));
    TEST_ASSERT_EQUAL_INT(3, tap->drain(sink));
    TEST_ASSERT_EQUAL_INT(0, tap->drain(sink));
    TEST_ASSERT_FALSE(tap->wait(5));   // nothing queued: the wait times out
}

// next(): one message per call, in order, a fragmented one whole; nothing
// queued: 0 at once with timeout 0, 0 after the timeout otherwise.
void test_next_hands_one_message_at_a_time_and_waits_no_longer_than_asked()
{
    const auto a = pattern(49, 11), b = pattern(836, 12), big = pattern(200000, 13);
    pub->publish("ONE", a.data(), static_cast<unsigned>(a.size()));
    pub->publish("TWO", b.data(), static_cast<unsigned>(b.size()));
    pub->publish("BIG", big.data(), static_cast<unsigned>(big.size()));
    std::vector<Got> got;
    auto sink = [&](const std::string &c, const unsigned char *d, std::size_t n, int64_t t) { got.push_back({c, {d, d + n}, t}); };
    for (int k = 1; k <= 3; ++k) {
        TEST_ASSERT_EQUAL_INT(1, tap->next(sink, 1000));
        TEST_ASSERT_EQUAL_INT(k, static_cast<int>(got.size()));
    }
    TEST_ASSERT_EQUAL_STRING("ONE", got[0].channel.c_str());
    TEST_ASSERT_TRUE(got[0].data == a);
    TEST_ASSERT_EQUAL_STRING("TWO", got[1].channel.c_str());
    TEST_ASSERT_TRUE(got[1].data == b);
    TEST_ASSERT_EQUAL_STRING("BIG", got[2].channel.c_str());
    TEST_ASSERT_TRUE(got[2].data == big);
    const auto t0 = std::chrono::steady_clock::now();
    TEST_ASSERT_EQUAL_INT(0, tap->next(sink, 0));
    TEST_ASSERT_EQUAL_INT(0, tap->next(sink, 30));
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    TEST_ASSERT_TRUE_MESSAGE(ms >= 29, "next returned before its timeout");
    TEST_ASSERT_EQUAL_INT(3, static_cast<int>(got.size()));
    // garbage alone completes no message: next goes on waiting, and says 0
    send_raw({'h', 'e', 'l', 'l', 'o'});
    TEST_ASSERT_EQUAL_INT(0, tap->next(sink, 20));
}

// next() waits in the read itself (SO_RCVTIMEO): a message that comes while
// it waits is taken at once; a timeout changed from call to call is the one
// honoured; a signal that interrupts the read does not end the wait early.
void handle_usr1(int) {}

void test_next_waits_in_the_read_for_as_long_as_each_call_asks()
{
    const auto a = pattern(57, 21);
    std::vector<Got> got;
    auto sink = [&](const std::string &c, const unsigned char *d, std::size_t n, int64_t t) { got.push_back({c, {d, d + n}, t}); };
    auto ms_since = [](std::chrono::steady_clock::time_point t0) {
        return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    };
    // a short wait, then a long one: the second is not cut to the first's
    auto t0 = std::chrono::steady_clock::now();
    TEST_ASSERT_EQUAL_INT(0, tap->next(sink, 5));
    TEST_ASSERT_TRUE_MESSAGE(ms_since(t0) >= 4, "next(5) returned before its timeout");
    std::thread later([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(40));
        pub->publish("LATE", a.data(), static_cast<unsigned>(a.size()));
    });
    t0 = std::chrono::steady_clock::now();
    TEST_ASSERT_EQUAL_INT(1, tap->next(sink, 2000));
    const double took = ms_since(t0);
    later.join();
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(got.size()));
    TEST_ASSERT_EQUAL_STRING("LATE", got[0].channel.c_str());
    TEST_ASSERT_TRUE_MESSAGE(took >= 35 && took < 1000, "the message that came while next waited was not taken when it came");
    // a signal (no SA_RESTART: the read fails with EINTR) mid-wait
    struct sigaction sa{}, old{};
    sa.sa_handler = handle_usr1;
    sigaction(SIGUSR1, &sa, &old);
    const pthread_t me = pthread_self();
    std::thread poke([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        pthread_kill(me, SIGUSR1);
    });
    t0 = std::chrono::steady_clock::now();
    TEST_ASSERT_EQUAL_INT(0, tap->next(sink, 60));
    const double waited = ms_since(t0);
    poke.join();
    sigaction(SIGUSR1, &old, nullptr);
    TEST_ASSERT_TRUE_MESSAGE(waited >= 59, "a signal ended next's wait before its timeout");
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(got.size()));
}

// A filtered receiver: short messages on other channels never reach its
// socket, fragmented ones on other channels are followed but not handed on.
void test_a_filtered_receiver_hands_on_only_its_channels()
{
    afm::BusTap mine(afm::kBusUrl);
    mine.accept_only({"AFM_CMD"});
    std::vector<Got> got;
    auto sink = [&](const std::string &c, const unsigned char *d, std::size_t n, int64_t t) { got.push_back({c, {d, d + n}, t}); };
    const auto a = pattern(40, 14), big = pattern(150000, 15);
    pub->publish("FW_STATE", a.data(), static_cast<unsigned>(a.size()));
    TEST_ASSERT_FALSE_MESSAGE(mine.wait(30), "a short message on another channel reached the socket");
    pub->publish("AFM_SCAN_LINE", big.data(), static_cast<unsigned>(big.size()));   // fragments pass the kernel
    TEST_ASSERT_EQUAL_INT(0, mine.next(sink, 50));
    pub->publish("AFM_CMD", a.data(), static_cast<unsigned>(a.size()));
    pub->publish("AFM_CMD", big.data(), static_cast<unsigned>(big.size()));
    TEST_ASSERT_EQUAL_INT(1, mine.next(sink, 1000));
    TEST_ASSERT_EQUAL_INT(1, mine.next(sink, 1000));
    TEST_ASSERT_EQUAL_INT(2, static_cast<int>(got.size()));
    TEST_ASSERT_TRUE(got[0].channel == "AFM_CMD" && got[0].data == a);
    TEST_ASSERT_TRUE(got[1].channel == "AFM_CMD" && got[1].data == big);
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(mine.dropped()));   // other channels' messages are not garbage
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(mine.abandoned()));
}

// The simulator's window on the record, from the recorder's receive buffer.
void test_the_log_window_follows_the_receive_buffer_within_its_bounds()
{
    TEST_ASSERT_EQUAL_INT(8, static_cast<int>(afm::log_window_blocks(0)));
    TEST_ASSERT_EQUAL_INT(8, static_cast<int>(afm::log_window_blocks(-1)));
    TEST_ASSERT_EQUAL_INT(8, static_cast<int>(afm::log_window_blocks(212992)));       // Linux's default rmem_max (6 blocks' worth)
    TEST_ASSERT_EQUAL_INT(13, static_cast<int>(afm::log_window_blocks(2 * 212992)));  // granted twice the request
    TEST_ASSERT_EQUAL_INT(64, static_cast<int>(afm::log_window_blocks(8 << 20)));     // the bus URL's 4 MB, doubled
    TEST_ASSERT_EQUAL_INT(64, static_cast<int>(afm::log_window_blocks(INT64_MAX)));
    // the tap reads back what the kernel granted: at least the URL's request
    // where rmem_max allows it (this namespace's), never nothing
    TEST_ASSERT_TRUE(tap->receive_buffer_bytes() > 0);
    TEST_ASSERT_TRUE(afm::log_window_blocks(tap->receive_buffer_bytes()) >= 8);
}

void test_a_url_it_cannot_use_is_refused_by_name()
{
    for (const char *url : {"tcpq://127.0.0.1:7700", "udpm://not-an-address:7667", "udpm://239.255.76.67:0?ttl=0", "udpm://239.255.76.67"}) {
        try {
            afm::BusTap t(url);
            TEST_FAIL_MESSAGE(url);
        } catch (const std::runtime_error &e) {
            TEST_ASSERT_NOT_NULL_MESSAGE(std::strstr(e.what(), url), e.what());
        }
    }
}

int main()
{
    if (!bus_fixtures::in_run("test_bus_tap")) return 2;
    tap = std::make_unique<afm::BusTap>(afm::kBusUrl);
    pub = afm::open_bus();
    raw = bus_fixtures::open_raw();
    UNITY_BEGIN();
    RUN_TEST(test_short_messages_come_whole_in_order_with_their_time);
    RUN_TEST(test_a_fragmented_message_comes_whole);
    RUN_TEST(test_two_senders_fragments_interleaved_each_come_whole);
    RUN_TEST(test_a_repeated_fragment_is_taken_once);
    RUN_TEST(test_what_lcm_would_drop_is_dropped_and_counted);
    RUN_TEST(test_a_new_message_abandons_an_unfinished_one);
    RUN_TEST(test_claimed_sizes_cost_no_memory_until_the_fragments_come);
    RUN_TEST(test_drain_takes_at_most_max_datagrams);
    RUN_TEST(test_next_hands_one_message_at_a_time_and_waits_no_longer_than_asked);
    RUN_TEST(test_next_waits_in_the_read_for_as_long_as_each_call_asks);
    RUN_TEST(test_a_filtered_receiver_hands_on_only_its_channels);
    RUN_TEST(test_the_log_window_follows_the_receive_buffer_within_its_bounds);
    RUN_TEST(test_a_url_it_cannot_use_is_refused_by_name);
    const int r = UNITY_END();
    close(raw);
    return r;
}
