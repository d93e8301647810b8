// Unity tests of the kernel's share of a subscription (common/bus_filter):
// the BPF program attached to a real UDP socket on 127.0.0.1, fed datagrams
// laid out as liblcm lays out a short message (magic "LC02", sequence
// number, channel and NUL, payload) and everything it must let the
// receiver (common/bus_tap) judge itself. (That liblcm's own datagrams pass
// is shown by every run of the bench, whose processes filter their sockets,
// and by test_bus_tap, where liblcm publishes to a filtered inbox.)
#include <unity.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "bus_filter.hpp"

namespace {

int rx = -1, tx = -1;
sockaddr_in to{};

std::string short_message(const std::string &channel, std::size_t payload = 16, uint32_t magic = 0x4c433032)
{
    std::string d(8, '\0');
    const uint32_t m = htonl(magic), seq = htonl(42);
    std::memcpy(&d[0], &m, 4);
    std::memcpy(&d[4], &seq, 4);
    d += channel;
    d += '\0';
    d += std::string(payload, 'x');
    return d;
}

void attach(const std::set<std::string> &channels) { TEST_ASSERT_TRUE(afm::bus_filter_attach(rx, channels)); }

// Sends `d`, then a marker the filter always passes (garbage), and reports
// whether `d` arrived before the marker.
bool passes(const std::string &d)
{
    const std::string marker = "??";   // shorter than a magic: always passes
    TEST_ASSERT_EQUAL_INT(static_cast<int>(d.size()), sendto(tx, d.data(), d.size(), 0, reinterpret_cast<sockaddr *>(&to), sizeof to));
    TEST_ASSERT_EQUAL_INT(2, sendto(tx, marker.data(), 2, 0, reinterpret_cast<sockaddr *>(&to), sizeof to));
    bool got = false;
    for (;;) {
        pollfd p{rx, POLLIN, 0};
        TEST_ASSERT_EQUAL_INT_MESSAGE(1, poll(&p, 1, 2000), "the marker never came");
        char buf[70000];
        const ssize_t n = recv(rx, buf, sizeof buf, 0);
        if (n == 2 && std::memcmp(buf, "??", 2) == 0 && d != marker) return got;
        if (n == static_cast<ssize_t>(d.size()) && std::memcmp(buf, d.data(), d.size()) == 0) {
            if (d == marker) return true;
            got = true;
        }
    }
}

}  // namespace

void setUp(void)
{
    rx = socket(AF_INET, SOCK_DGRAM, 0);
    tx = socket(AF_INET, SOCK_DGRAM, 0);
    to = sockaddr_in{};
    to.sin_family = AF_INET;
    to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    TEST_ASSERT_EQUAL_INT(0, bind(rx, reinterpret_cast<sockaddr *>(&to), sizeof to));
    socklen_t n = sizeof to;
    getsockname(rx, reinterpret_cast<sockaddr *>(&to), &n);
}

void tearDown(void)
{
    close(rx);
    close(tx);
}

void test_a_subscribed_channel_passes_and_another_does_not(void)
{
    attach({"AFM_CMD", "HAPTIC_POSE"});
    TEST_ASSERT_TRUE(passes(short_message("AFM_CMD")));
    TEST_ASSERT_TRUE(passes(short_message("HAPTIC_POSE")));
    TEST_ASSERT_FALSE(passes(short_message("FW_STATE")));
    TEST_ASSERT_FALSE(passes(short_message("AFM_ANALOG")));
}

void test_a_prefix_or_an_extension_of_a_channel_does_not_pass(void)
{
    attach({"AFM_CMD"});
    TEST_ASSERT_FALSE(passes(short_message("AFM_CM")));
    TEST_ASSERT_FALSE(passes(short_message("AFM_CMDX")));
    TEST_ASSERT_FALSE(passes(short_message("AFM_CMD_")));
    TEST_ASSERT_FALSE(passes(short_message("afm_cmd")));   // channels are case-sensitive, as in liblcm
    TEST_ASSERT_FALSE(passes(short_message("")));
}

void test_names_of_every_length_modulo_4_are_compared_to_their_last_byte(void)
{
    // 1, 2, 3, 4, 5 ... 9 characters plus the NUL: every tail of word, half and byte loads
    const char *names[] = {"A", "AB", "ABC", "ABCD", "ABCDE", "ABCDEF", "ABCDEFG", "ABCDEFGH", "ABCDEFGHI"};
    for (const char *n : names) {
        attach({n});
        TEST_ASSERT_TRUE_MESSAGE(passes(short_message(n)), n);
        std::string last = n;
        last.back() = static_cast<char>(last.back() + 1);
        TEST_ASSERT_FALSE_MESSAGE(passes(short_message(last)), n);
    }
}

void test_a_message_with_no_payload_after_its_name_passes(void)
{
    attach({"HAPTIC_FORCE"});
    TEST_ASSERT_TRUE(passes(short_message("HAPTIC_FORCE", 0)));
}

void test_a_datagram_too_short_for_a_longer_subscribed_name_is_compared_with_the_next(void)
{
    // a longer name first (sorted: "AAAAAAAAAAAAAAAAAAAAAA" < "B") whose
    // comparison would read past this short datagram: skipped, not an abort
    attach({std::string(40, 'A'), "B"});
    TEST_ASSERT_TRUE(passes(short_message("B", 0)));
    TEST_ASSERT_FALSE(passes(short_message("C", 0)));
}

void test_what_the_receiver_judges_itself_always_passes(void)
{
    attach({"AFM_CMD"});
    TEST_ASSERT_TRUE(passes(std::string("x")));                                  // shorter than a magic
    TEST_ASSERT_TRUE(passes(short_message("FW_STATE", 16, 0x4c433033)));            // a fragment ("LC03")
    TEST_ASSERT_TRUE(passes(short_message("FW_STATE", 16, 0xdeadbeef)));            // garbage
    TEST_ASSERT_FALSE(passes(short_message("LCM_SELF_TEST")));                   // liblcm's own test: not subscribed, not read
    TEST_ASSERT_FALSE(passes(std::string("LC02\0\0\0\x2a", 8)));                 // a short message with no name at all
}

void test_an_empty_subscription_set_passes_no_short_message(void)
{
    attach({});
    TEST_ASSERT_FALSE(passes(short_message("LCM_SELF_TEST")));
    TEST_ASSERT_FALSE(passes(short_message("AFM_CMD")));
    TEST_ASSERT_TRUE(passes(short_message("AFM_CMD", 16, 0x4c433033)));   // a fragment: the receiver's to judge
}

void test_attaching_again_replaces_the_filter(void)
{
    attach({"AFM_CMD"});
    TEST_ASSERT_FALSE(passes(short_message("FW_STATE")));
    attach({"AFM_CMD", "FW_STATE"});
    TEST_ASSERT_TRUE(passes(short_message("FW_STATE")));
    TEST_ASSERT_TRUE(passes(short_message("AFM_CMD")));
}

void test_a_socket_that_is_not_one_is_refused(void)
{
    TEST_ASSERT_FALSE(afm::bus_filter_attach(-1, {"AFM_CMD"}));
}

void test_many_channels_keep_every_jump_in_range(void)
{
    std::set<std::string> all;
    for (int i = 0; i < 40; ++i) all.insert("CHANNEL_NUMBER_" + std::to_string(i));
    attach(all);
    TEST_ASSERT_TRUE(passes(short_message("CHANNEL_NUMBER_0")));
    TEST_ASSERT_TRUE(passes(short_message("CHANNEL_NUMBER_39")));
    TEST_ASSERT_FALSE(passes(short_message("CHANNEL_NUMBER_40")));
}

void test_an_absurdly_long_name_turns_the_filter_off_rather_than_break_it(void)
{
    attach({std::string(300, 'Q')});
    TEST_ASSERT_TRUE(passes(short_message("ANYTHING")));
}

std::string channel_of(const std::string &d)
{
    return afm::lcm_datagram_channel(reinterpret_cast<const unsigned char *>(d.data()), d.size());
}

// A fragment ("LC03"): magic, sequence, message size, offset, fragment number and count, then (fragment 0) the name.
std::string fragment(const std::string &channel, uint16_t number)
{
    std::string d = short_message("", 0, 0x4c433033).substr(0, 8);
    d += std::string(8, '\0');   // size and offset
    d += static_cast<char>(number >> 8);
    d += static_cast<char>(number & 0xff);
    d += std::string("\0\2", 2);   // two fragments
    if (number == 0) d += channel + '\0';
    return d + "payload";
}

void test_the_channel_of_a_datagram_is_read_as_liblcm_lays_it_out(void)
{
    TEST_ASSERT_EQUAL_STRING("AFM_CMD", channel_of(short_message("AFM_CMD")).c_str());
    TEST_ASSERT_EQUAL_STRING("HAPTIC_FORCE", channel_of(short_message("HAPTIC_FORCE", 0)).c_str());
    TEST_ASSERT_EQUAL_STRING("AFM_SCAN_LINE", channel_of(fragment("AFM_SCAN_LINE", 0)).c_str());
    // nothing to read: a later fragment, no name, no NUL, garbage, too short
    TEST_ASSERT_EQUAL_STRING("", channel_of(fragment("AFM_SCAN_LINE", 1)).c_str());
    TEST_ASSERT_EQUAL_STRING("", channel_of(short_message("")).c_str());
    TEST_ASSERT_EQUAL_STRING("", channel_of(short_message("FW_STATE", 0).substr(0, 14)).c_str());
    TEST_ASSERT_EQUAL_STRING("", channel_of(short_message("FW_STATE", 16, 0xdeadbeef)).c_str());
    TEST_ASSERT_EQUAL_STRING("", channel_of(std::string("LC0")).c_str());
    TEST_ASSERT_EQUAL_STRING("", channel_of(std::string()).c_str());
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_a_subscribed_channel_passes_and_another_does_not);
    RUN_TEST(test_a_prefix_or_an_extension_of_a_channel_does_not_pass);
    RUN_TEST(test_names_of_every_length_modulo_4_are_compared_to_their_last_byte);
    RUN_TEST(test_a_message_with_no_payload_after_its_name_passes);
    RUN_TEST(test_a_datagram_too_short_for_a_longer_subscribed_name_is_compared_with_the_next);
    RUN_TEST(test_what_the_receiver_judges_itself_always_passes);
    RUN_TEST(test_an_empty_subscription_set_passes_no_short_message);
    RUN_TEST(test_attaching_again_replaces_the_filter);
    RUN_TEST(test_a_socket_that_is_not_one_is_refused);
    RUN_TEST(test_many_channels_keep_every_jump_in_range);
    RUN_TEST(test_an_absurdly_long_name_turns_the_filter_off_rather_than_break_it);
    RUN_TEST(test_the_channel_of_a_datagram_is_read_as_liblcm_lays_it_out);
    return UNITY_END();
}
