// Unity tests of the run's bus key and the trailer each datagram carries
// (bus/bus_key.hpp): what the key signs verifies, anything changed (a
// byte of the message, the channel, the sequence, the tag, another key)
// does not, a message cut short or without a trailer is named so, a
// sequence is taken once (and a reordered one within the window), and the
// key reaches a child through an inherited memfd, read once and closed;
// and the bus's gathering (BusGather, every receiver's) hands on a signed
// message stripped of its trailer, refuses and counts one without proof,
// with a bad tag or a sequence replayed, and (not enforcing) hands on what
// it cannot prove as it came.
#include "bus_key.hpp"
#include "bus_tap.hpp"   // (with nlohmann/json) before unity.h, whose isnan macro breaks nlohmann/json

#include <unity.h>

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <string>
#include <vector>

using afm::BusKey;

namespace {

std::vector<unsigned char> message(std::size_t n)
{
    std::vector<unsigned char> m(n);
    for (std::size_t i = 0; i < n; ++i) m[i] = static_cast<unsigned char>(i * 37 + 11);
    return m;
}

}  // namespace

void setUp(void) {}
void tearDown(void) {}

static void test_what_the_key_signs_verifies_and_nothing_else(void)
{
    const BusKey k = BusKey::make(), other = BusKey::make();
    for (std::size_t n : {0u, 1u, 27u, 28u, 100u, 4096u}) {
        std::vector<unsigned char> m = message(n);
        k.sign("HAPTIC_POSE", 42, &m);
        TEST_ASSERT_EQUAL_UINT64(n + BusKey::kTrailerBytes, m.size());
        uint64_t seq = 0;
        TEST_ASSERT_EQUAL_INT(static_cast<int>(BusKey::Check::ok), static_cast<int>(k.verify("HAPTIC_POSE", m.data(), m.size(), &seq)));
        TEST_ASSERT_EQUAL_UINT64(42, seq);
        TEST_ASSERT_EQUAL_INT(static_cast<int>(BusKey::Check::bad_mac), static_cast<int>(k.verify("HAPTIC_POSX", m.data(), m.size(), &seq)));
        TEST_ASSERT_EQUAL_INT(static_cast<int>(BusKey::Check::bad_mac), static_cast<int>(other.verify("HAPTIC_POSE", m.data(), m.size(), &seq)));
        // every byte but the magic's, flipped, is refused as a bad tag
        for (std::size_t i = 0; i < m.size(); ++i) {
            if (i >= n && i < n + 4) continue;
            m[i] ^= 0x01;
            TEST_ASSERT_EQUAL_INT(static_cast<int>(BusKey::Check::bad_mac), static_cast<int>(k.verify("HAPTIC_POSE", m.data(), m.size(), &seq)));
            m[i] ^= 0x01;
        }
        m[n] ^= 0x01;   // the magic: no trailer at all
        TEST_ASSERT_EQUAL_INT(static_cast<int>(BusKey::Check::no_trailer), static_cast<int>(k.verify("HAPTIC_POSE", m.data(), m.size(), &seq)));
    }
}

static void test_a_message_without_a_trailer_is_named_so(void)
{
    const BusKey k = BusKey::make();
    const std::vector<unsigned char> m = message(200);
    uint64_t seq = 0;
    TEST_ASSERT_EQUAL_INT(static_cast<int>(BusKey::Check::no_trailer), static_cast<int>(k.verify("AFM_CMD", m.data(), m.size(), &seq)));
    TEST_ASSERT_EQUAL_INT(static_cast<int>(BusKey::Check::no_trailer), static_cast<int>(k.verify("AFM_CMD", m.data(), 10, &seq)));
    TEST_ASSERT_EQUAL_INT(static_cast<int>(BusKey::Check::no_trailer), static_cast<int>(k.verify("AFM_CMD", m.data(), 0, &seq)));
    TEST_ASSERT_EQUAL_STRING("no_trailer", afm::check_name(BusKey::Check::no_trailer));
    TEST_ASSERT_EQUAL_STRING("bad_mac", afm::check_name(BusKey::Check::bad_mac));
}

static void test_a_sequence_is_taken_once(void)
{
    afm::ReplayWindow w;
    TEST_ASSERT_TRUE(w.take(1, "A", 10));
    TEST_ASSERT_FALSE(w.take(1, "A", 10));   // the same again: replayed
    TEST_ASSERT_TRUE(w.take(1, "B", 10));    // another channel
    TEST_ASSERT_TRUE(w.take(2, "A", 10));    // another sender
    TEST_ASSERT_TRUE(w.take(1, "A", 12));
    TEST_ASSERT_TRUE(w.take(1, "A", 11));    // reordered, within the window
    TEST_ASSERT_FALSE(w.take(1, "A", 11));
    TEST_ASSERT_TRUE(w.take(1, "A", 12 + afm::ReplayWindow::kWindow));
    TEST_ASSERT_FALSE(w.take(1, "A", 12));   // now too old to tell
    TEST_ASSERT_TRUE(w.take(1, "A", 13 + afm::ReplayWindow::kWindow));
    TEST_ASSERT_TRUE(w.take(1, "A", 1000000));   // a jump past the window clears it
    TEST_ASSERT_FALSE(w.take(1, "A", 13 + afm::ReplayWindow::kWindow));
}

static void test_the_key_reaches_a_child_through_an_inherited_descriptor(void)
{
    const BusKey k = BusKey::make();
    const int fd = k.memfd();
    TEST_ASSERT_TRUE(fd >= 0);
    TEST_ASSERT_TRUE(fcntl(fd, F_GETFD) & FD_CLOEXEC);
    std::vector<unsigned char> m = message(64);
    k.sign("FW_STATE", 7, &m);
    const pid_t pid = fork();
    if (pid == 0) {
        // as the launcher's spawn does: the memfd at kBusKeyFd, named in the environment
        if (dup2(fd, afm::kBusKeyFd) != afm::kBusKeyFd) _exit(10);
        setenv(afm::kBusKeyFdEnv, std::to_string(afm::kBusKeyFd).c_str(), 1);
        const auto got = BusKey::inherited();
        if (!got) _exit(11);
        uint64_t seq = 0;
        if (got->verify("FW_STATE", m.data(), m.size(), &seq) != BusKey::Check::ok || seq != 7) _exit(12);
        if (fcntl(afm::kBusKeyFd, F_GETFD) != -1) _exit(13);   // read once, then closed
        if (std::getenv(afm::kBusKeyFdEnv)) _exit(14);
        if (BusKey::inherited()) _exit(15);   // nothing left to inherit
        _exit(0);
    }
    int st = 0;
    waitpid(pid, &st, 0);
    close(fd);
    TEST_ASSERT_TRUE(WIFEXITED(st));
    TEST_ASSERT_EQUAL_INT(0, WEXITSTATUS(st));
}

// An LCM short datagram ("LC02", a sequence, the channel and its NUL, the payload).
static std::vector<unsigned char> datagram(const std::string &channel, const std::vector<unsigned char> &payload)
{
    std::vector<unsigned char> d = {'L', 'C', '0', '2', 0, 0, 0, 1};
    d.insert(d.end(), channel.begin(), channel.end());
    d.push_back(0);
    d.insert(d.end(), payload.begin(), payload.end());
    return d;
}

static void test_the_gathering_hands_on_only_what_carries_its_proof(void)
{
    const BusKey k = BusKey::make(), other = BusKey::make();
    for (bool enforce : {true, false}) {
        afm::BusGather g;
        g.prove_with(&k, enforce);
        std::vector<std::vector<unsigned char>> got;
        const afm::BusGather::Sink sink = [&](const std::string &, const unsigned char *d, std::size_t n, int64_t) {
            got.emplace_back(d, d + n);
        };
        const std::vector<unsigned char> plain = message(40);
        std::vector<unsigned char> signed1 = plain, signed2 = plain, foreign = plain, bad = plain;
        k.sign("AFM_CMD", 1, &signed1);
        k.sign("AFM_CMD", 2, &signed2);
        other.sign("AFM_CMD", 3, &foreign);
        k.sign("AFM_CMD", 4, &bad);
        bad[3] ^= 1;
        auto feed = [&](const std::vector<unsigned char> &payload, uint16_t port) {
            const auto d = datagram("AFM_CMD", payload);
            return g.take(d.data(), d.size(), 0x7F000001u, port, 0, sink);
        };
        TEST_ASSERT_EQUAL_INT(1, feed(signed1, 40000));
        TEST_ASSERT_TRUE(got.back() == plain);   // stripped
        TEST_ASSERT_EQUAL_INT(1, feed(signed2, 40000));
        TEST_ASSERT_EQUAL_INT(enforce ? 0 : 1, feed(signed1, 40000));   // sequence 1 again: replayed
        TEST_ASSERT_EQUAL_INT(1, feed(signed1, 40001));   // another sender's window
        TEST_ASSERT_EQUAL_INT(enforce ? 0 : 1, feed(plain, 40000));
        TEST_ASSERT_EQUAL_INT(enforce ? 0 : 1, feed(foreign, 40000));
        TEST_ASSERT_EQUAL_INT(enforce ? 0 : 1, feed(bad, 40000));
        const auto j = g.unproven().to_json();
        TEST_ASSERT_EQUAL_INT64(enforce ? 4 : 0, j["total"].get<int64_t>());
        TEST_ASSERT_EQUAL_INT64(enforce ? 1 : 0, j["by_reason"]["replayed"].get<int64_t>());
        TEST_ASSERT_EQUAL_INT64(enforce ? 1 : 0, j["by_reason"]["no_trailer"].get<int64_t>());
        TEST_ASSERT_EQUAL_INT64(enforce ? 2 : 0, j["by_reason"]["bad_mac"].get<int64_t>());
        if (enforce) TEST_ASSERT_EQUAL_INT64(4, j["by_channel"]["AFM_CMD"].get<int64_t>());
        if (!enforce) TEST_ASSERT_TRUE(got.back() == bad);   // handed on as it came
    }
}

static void test_a_flood_of_channel_names_costs_no_memory(void)
{
    afm::ProofCounts c;
    for (int i = 0; i < 1000; ++i) c.count("no_trailer", "CH" + std::to_string(i));
    c.count("bad_mac", "\xff\x1b[31m");
    const auto j = c.to_json();
    TEST_ASSERT_EQUAL_INT64(1001, j["total"].get<int64_t>());
    TEST_ASSERT_EQUAL_UINT64(afm::ProofCounts::kMaxChannels + 1, j["by_channel"].size());
    TEST_ASSERT_EQUAL_INT64(1001 - static_cast<int64_t>(afm::ProofCounts::kMaxChannels),
                            j["by_channel"][afm::ProofCounts::kOtherChannels].get<int64_t>());
    (void)j.dump();   // strict: every name escaped
}

static void test_a_descriptor_that_holds_no_key_is_refused(void)
{
    int p[2];
    TEST_ASSERT_EQUAL_INT(0, pipe(p));
    close(p[1]);
    setenv(afm::kBusKeyFdEnv, std::to_string(p[0]).c_str(), 1);
    bool threw = false;
    try {
        BusKey::inherited();
    } catch (const std::runtime_error &e) {
        threw = std::string(e.what()).find(afm::kBusKeyFdEnv) != std::string::npos;
    }
    TEST_ASSERT_TRUE(threw);
    setenv(afm::kBusKeyFdEnv, "x3", 1);
    threw = false;
    try {
        BusKey::inherited();
    } catch (const std::runtime_error &) {
        threw = true;
    }
    TEST_ASSERT_TRUE(threw);
    unsetenv(afm::kBusKeyFdEnv);
    TEST_ASSERT_FALSE(BusKey::inherited().has_value());
}

int main(void)
{
    UNITY_BEGIN();
    RUN_TEST(test_what_the_key_signs_verifies_and_nothing_else);
    RUN_TEST(test_a_message_without_a_trailer_is_named_so);
    RUN_TEST(test_a_sequence_is_taken_once);
    RUN_TEST(test_the_key_reaches_a_child_through_an_inherited_descriptor);
    RUN_TEST(test_a_descriptor_that_holds_no_key_is_refused);
    RUN_TEST(test_the_gathering_hands_on_only_what_carries_its_proof);
    RUN_TEST(test_a_flood_of_channel_names_costs_no_memory);
    return UNITY_END();
}
