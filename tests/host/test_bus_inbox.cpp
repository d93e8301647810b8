// Unity tests of every process's inbox on the bus (bus/inbox) and of who may
// send (bus/senders): an inbox reads its own socket on the caller's thread
// and starts no receive thread; a batched inbox (the renderer's) loses
// nothing while its caller is busy; a heartbeat repeats "ready" at its own
// period; a message from a process that does not publish its channel is
// foreign, counted and never handed on; reading a gone process's parent
// never throws.
// Runs inside a private network namespace (run/in_netns.sh, from ctest):
// the bus is real udpm multicast on its loopback.
#include "inbox.hpp"   // the project's headers before unity.h, whose isnan macro breaks nlohmann/json
#include "senders.hpp"
#include "afm/heartbeat_t.hpp"
#include "afm/scan_line_t.hpp"
#include "afm_channels.h"
#include "bus.hpp"
#include "bus_tap.hpp"

#include "bus_fixtures.hpp"

#include <dirent.h>
#include <sys/wait.h>
#include <unistd.h>

#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

using bus_fixtures::pattern;

namespace {

std::unique_ptr<afm::BusTap> tap;   // drained before each test; its receive buffer sizes the batched test
std::unique_ptr<lcm::LCM> pub;
int raw = -1;

int threads_of_this_process()
{
    int n = 0;
    DIR *d = opendir("/proc/self/task");
    while (dirent *e = readdir(d))
        if (e->d_name[0] != '.') ++n;
    closedir(d);
    return n;
}

// Publishes `n` messages of `bytes` on `channel`, paced (a pause every 20)
// so that a receive thread that keeps up never has its socket full.
void publish_paced(const char *channel, int n, std::size_t bytes)
{
    const auto a = pattern(bytes, 17);
    for (int i = 0; i < n; ++i) {
        pub->publish(channel, a.data(), static_cast<unsigned>(a.size()));
        if (i % 20 == 19) usleep(2000);
    }
}

}  // namespace

void setUp()
{
    tap->drain([](const std::string &, const unsigned char *, std::size_t, int64_t) {});   // nothing left from the last test
}
void tearDown() {}

// A heartbeat says "ready" every kReadyPeriodUs, whatever period its caller
// gives (the simulator starts once it has heard every peer: bus.hpp), and
// any other state at most once per the period given, unless it changed.
void test_a_heartbeat_repeats_ready_at_its_own_period()
{
    afm::Inbox inbox(pub.get());
    std::vector<std::string> states;
    inbox.on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [&](const afm::heartbeat_t &m) {
        states.push_back(m.state);
        return afm::Reject::none;
    });
    afm::Heartbeat hb(*pub, "test_bus_inbox");
    const auto past_ready_period = std::chrono::microseconds(afm::kReadyPeriodUs + 5000);
    hb.maybe_send(afm::RunState::ready, -1, 0, 1000000);   // a new state: sent
    hb.maybe_send(afm::RunState::ready, -1, 0, 1000000);   // within the ready period: not
    std::this_thread::sleep_for(past_ready_period);
    hb.maybe_send(afm::RunState::ready, -1, 0, 1000000);   // past it, although the caller said 1 s
    hb.maybe_send(afm::RunState::running, 0, 0, 1000000);  // a new state
    std::this_thread::sleep_for(past_ready_period);
    hb.maybe_send(afm::RunState::running, 0, 0, 1000000);  // within the caller's 1 s: not
    while (inbox.handle(100) > 0) {}
    TEST_ASSERT_EQUAL_INT(3, static_cast<int>(states.size()));
    TEST_ASSERT_EQUAL_STRING("ready", states[0].c_str());
    TEST_ASSERT_EQUAL_STRING("ready", states[1].c_str());
    TEST_ASSERT_EQUAL_STRING("running", states[2].c_str());
}

// An inbox on the bus: its own socket, read in handle() on the caller's
// thread (no liblcm receive thread), its handler called once per message,
// only for its channels; the process still publishes through liblcm.
void test_an_inbox_on_the_bus_reads_its_own_socket_on_the_callers_thread()
{
    const int threads = threads_of_this_process();
    afm::Inbox inbox(pub.get());
    int beats = 0;
    std::string last;
    inbox.on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [&](const afm::heartbeat_t &m) {
        ++beats;
        last = m.name;
        return afm::Reject::none;
    });
    afm::Heartbeat hb(*pub, "test_bus_inbox");
    const auto a = pattern(40, 16);
    pub->publish("FW_STATE", a.data(), static_cast<unsigned>(a.size()));   // not the inbox's channel
    hb.send(afm::RunState::ready, -1, 0);
    hb.send(afm::RunState::running, 0, 0);
    TEST_ASSERT_EQUAL_INT(1, inbox.handle(1000));
    TEST_ASSERT_EQUAL_INT(1, beats);
    TEST_ASSERT_EQUAL_INT(1, inbox.handle(1000));
    TEST_ASSERT_EQUAL_INT(2, beats);
    TEST_ASSERT_EQUAL_STRING("test_bus_inbox", last.c_str());
    TEST_ASSERT_EQUAL_INT(0, inbox.handle(20));
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(inbox.rejected().total()));
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(inbox.bus_dropped()));
    TEST_ASSERT_EQUAL_INT_MESSAGE(threads, threads_of_this_process(), "the inbox started a thread");
    // a message its decoder refuses is counted, not handed on
    pub->publish(AFM_CH_AFM_HEARTBEAT, a.data(), static_cast<unsigned>(a.size()));
    TEST_ASSERT_EQUAL_INT(1, inbox.handle(1000));
    TEST_ASSERT_EQUAL_INT(2, beats);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(inbox.rejected().total()));
    // garbage is the receiver's to drop, before any subscription
    bus_fixtures::send_raw(raw, {'n', 'o', 'i', 's', 'e'});
    TEST_ASSERT_EQUAL_INT(0, inbox.handle(50));
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(inbox.bus_dropped()));
}

// A batched inbox (the renderer's): its thread keeps taking the bus while
// the caller is busy for longer than the socket's buffer lasts; it loses
// nothing there, where an inbox read on call loses what overflows. One
// thread more, started by the first handle(); a subscription after it is a
// programming error.
void test_a_batched_inbox_loses_nothing_while_its_caller_is_busy()
{
    // twice what the socket holds, at the kernel's 8448 bytes for a 6200-byte datagram
    const int n = static_cast<int>(2 * tap->receive_buffer_bytes() / 8448) + 1;
    int on_call = 0, batched = 0;
    setenv("AFM_ADMIT_ANY_SENDER", "1", 1);   // this test program publishes no scan lines in a run (senders.hpp)
    afm::Inbox slow(pub.get());
    slow.on<afm::scan_line_t>(AFM_CH_AFM_SCAN_LINE, [&](const afm::scan_line_t &) { return afm::Reject::none; });
    afm::Inbox busy(pub.get(), 500);
    busy.on<afm::scan_line_t>(AFM_CH_AFM_SCAN_LINE, [&](const afm::scan_line_t &) { return afm::Reject::none; });
    const int threads = threads_of_this_process();
    TEST_ASSERT_EQUAL_INT(0, busy.handle(0));   // starts its thread
    TEST_ASSERT_EQUAL_INT(threads + 1, threads_of_this_process());
    try {
        busy.on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [](const afm::heartbeat_t &) { return afm::Reject::none; });
        TEST_FAIL_MESSAGE("a subscription after the thread started was taken");
    } catch (const std::logic_error &) {
    }
    publish_paced(AFM_CH_AFM_SCAN_LINE, n, 6200);   // neither caller reads meanwhile
    usleep(100000);
    while (busy.handle(200) > 0) ++batched;
    while (slow.handle(0) > 0) ++on_call;
    // (the payload is no scan line: each is refused by the decoder, and counted)
    TEST_ASSERT_EQUAL_INT(n, batched);
    TEST_ASSERT_EQUAL_INT(n, static_cast<int>(busy.rejected().total()));
    TEST_ASSERT_TRUE_MESSAGE(on_call < n, "the socket held more than its buffer");
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(busy.bus_dropped()));
    unsetenv("AFM_ADMIT_ANY_SENDER");
}

// Who may send (senders.hpp): the kernel names the sender by its socket. A
// scan line from this program, which publishes none in a run, is foreign,
// counted under its port, program and pid, and never handed on; its
// heartbeat (every process publishes them) is taken.
void test_a_message_from_a_process_that_does_not_publish_its_channel_is_foreign()
{
    afm::Inbox inbox(pub.get());
    int lines = 0, beats = 0;
    inbox.on<afm::scan_line_t>(AFM_CH_AFM_SCAN_LINE, [&](const afm::scan_line_t &) { ++lines; return afm::Reject::none; });
    inbox.on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [&](const afm::heartbeat_t &) { ++beats; return afm::Reject::none; });
    afm::Heartbeat hb(*pub, "test_bus_inbox");
    hb.maybe_send(afm::RunState::ready, -1, 0, 1000000);
    publish_paced(AFM_CH_AFM_SCAN_LINE, 5, 100);
    while (inbox.handle(100) > 0) {}
    TEST_ASSERT_EQUAL_INT(1, beats);
    TEST_ASSERT_EQUAL_INT(0, lines);
    const nlohmann::json rep = inbox.report();
    TEST_ASSERT_EQUAL_INT(5, rep["foreign_datagrams"].get<int>());
    const std::string who = rep["foreign"][AFM_CH_AFM_SCAN_LINE].begin().key();
    std::printf("foreign: %s\n", who.c_str());
    TEST_ASSERT_TRUE(who.find("test_bus_inbox, pid " + std::to_string(getpid())) != std::string::npos);
    TEST_ASSERT_FALSE(afm::Senders::publishes("test_bus_inbox", AFM_CH_AFM_SCAN_LINE));
    TEST_ASSERT_TRUE(afm::Senders::publishes("sim_afm", AFM_CH_AFM_SCAN_LINE));
    TEST_ASSERT_TRUE(afm::Senders::publishes("operator", AFM_CH_AFM_SCAN_REQ));
    TEST_ASSERT_TRUE(afm::Senders::publishes("renderer", AFM_CH_AFM_SCAN_REQ));
    TEST_ASSERT_FALSE(afm::Senders::publishes("fw_node", AFM_CH_HAPTIC_POSE));
    TEST_ASSERT_TRUE(afm::Senders::publishes("anything", AFM_CH_AFM_HEARTBEAT));
}

// A process that goes while its /proc/PID/stat is read made read() fail with
// ESRCH, which libstdc++'s istreambuf_iterator threw as std::ios_failure:
// the launcher of a paper run aborted (exit 134). Children exit at once and
// are reaped by a second thread while this one reads their parent: nothing
// throws (an exception ends this test as a crash). The answers are not
// held: once reaped, a pid may be some other task's (the reaper thread's
// own id among them).
void test_the_parent_of_a_process_that_goes_is_minus_1_never_an_exception()
{
    TEST_ASSERT_EQUAL_INT(getppid(), afm::Senders::parent_pid(getpid()));
    const pid_t gone = fork();
    if (gone == 0) _exit(0);
    waitpid(gone, nullptr, 0);
    TEST_ASSERT_EQUAL_INT(-1, afm::Senders::parent_pid(gone));
    for (int i = 0; i < 300; ++i) {
        const pid_t kid = fork();
        if (kid == 0) _exit(0);
        std::thread reaper([kid] { waitpid(kid, nullptr, 0); });
        for (int k = 0; k < 20; ++k) (void)afm::Senders::parent_pid(kid);
        reaper.join();
    }
}

int main()
{
    if (!bus_fixtures::in_run("test_bus_inbox")) return 2;
    tap = std::make_unique<afm::BusTap>(afm::kBusUrl);
    pub = afm::open_bus();
    raw = bus_fixtures::open_raw();
    UNITY_BEGIN();
    RUN_TEST(test_an_inbox_on_the_bus_reads_its_own_socket_on_the_callers_thread);
    RUN_TEST(test_a_heartbeat_repeats_ready_at_its_own_period);
    RUN_TEST(test_a_batched_inbox_loses_nothing_while_its_caller_is_busy);
    RUN_TEST(test_a_message_from_a_process_that_does_not_publish_its_channel_is_foreign);
    RUN_TEST(test_the_parent_of_a_process_that_goes_is_minus_1_never_an_exception);
    const int r = UNITY_END();
    close(raw);
    return r;
}
