// The page's hand pipe (operator/hand_input.hpp), without a run: lines
// written to a real pipe, read by poll(). HAND sets the hand's command; SCAN
// asks for a local scan, taken once (the newest); a line that is neither,
// or out of the field or range, is refused, counted, and changes nothing.
#include <unistd.h>

#include <cmath>
#include <string>

#include "hand_input.hpp"
#include "../scene_text.hpp"

extern "C" {
#include "unity.h"
}

void setUp() {}
void tearDown() {}

// A 2000 nm field centred on (0, 0), 128 px: a scan's side at least 4 px (62.5 nm).
static const char *kScene =
    "name: t\nseed: 1\nduration_s: 1\ntime_mode: realtime\nsample: {substrate: glass, field_nm: 2000}\n"
    "operator:\n  mode: browser\n  load_nN: 5\n  path_nm: [[0, -700]]\noutputs: {image_px: 128, video: none}\n";

struct Pipe {
    int r = -1, w = -1;
    Pipe()
    {
        int fd[2];
        TEST_ASSERT_EQUAL(0, pipe(fd));
        r = fd[0];
        w = fd[1];
    }
    ~Pipe() { close(r); close(w); }
    void say(const std::string &s) { TEST_ASSERT_EQUAL(static_cast<ssize_t>(s.size()), write(w, s.data(), s.size())); }
};

void test_hand_and_scan_commands_are_taken()
{
    const afm::Scene s = scene_from_text(kScene);
    Pipe p;
    afm::HandInput in(s, p.r);
    afm::HandInput::ScanAsk a{};
    TEST_ASSERT_FALSE(in.take_scan(&a));
    p.say("HAND 10 -650 7.5 1\nSCAN 0 -300 500\n");
    in.poll();
    TEST_ASSERT_EQUAL(1, in.taken());
    TEST_ASSERT_EQUAL(1, in.scans_asked());
    TEST_ASSERT_EQUAL(0, in.refused());
    TEST_ASSERT_EQUAL_DOUBLE(-650, in.command().aim_nm.y);
    TEST_ASSERT_TRUE(in.command().engaged);
    TEST_ASSERT_TRUE(in.take_scan(&a));
    TEST_ASSERT_EQUAL_DOUBLE(0, a.center_nm.x);
    TEST_ASSERT_EQUAL_DOUBLE(-300, a.center_nm.y);
    TEST_ASSERT_EQUAL_DOUBLE(500, a.size_nm);
    TEST_ASSERT_FALSE(in.take_scan(&a));   // taken once
    // two before a take: both counted, the newest waits
    p.say("SCAN 100 100 200\nSCAN -1000 1000 2000\n");
    in.poll();
    TEST_ASSERT_EQUAL(3, in.scans_asked());
    TEST_ASSERT_TRUE(in.take_scan(&a));
    TEST_ASSERT_EQUAL_DOUBLE(-1000, a.center_nm.x);
    TEST_ASSERT_EQUAL_DOUBLE(2000, a.size_nm);
}

void test_bad_scans_are_refused_and_counted()
{
    const afm::Scene s = scene_from_text(kScene);
    Pipe p;
    afm::HandInput in(s, p.r);
    const char *bad[] = {
        "SCAN 1001 0 500\n",      // centre outside the field
        "SCAN 0 -1000.5 500\n",   // outside, in y
        "SCAN 0 0 60\n",          // under 4 display pixels (62.5 nm)
        "SCAN 0 0 2000.1\n",      // over the field's side
        "SCAN 0 0 0\n",
        "SCAN 0 0 -100\n",
        "SCAN nan 0 500\n",
        "SCAN 0 0 inf\n",
        "SCAN 0 0\n",             // a number missing
        "SCAN 0 0 500 1\n",       // one too many
        "SCAN 0 0 500x\n",
        "scan 0 0 500\n",         // the word is upper case
        "PUSH 1 0 0\n",           // not a command (yet)
    };
    int n = 0;
    for (const char *line : bad) {
        p.say(line);
        in.poll();
        TEST_ASSERT_EQUAL_MESSAGE(++n, in.refused(), line);
    }
    afm::HandInput::ScanAsk a{};
    TEST_ASSERT_FALSE(in.take_scan(&a));
    TEST_ASSERT_EQUAL(0, in.scans_asked());
    TEST_ASSERT_EQUAL(0, in.taken());
    // the hand stays where the scene starts it, lifted
    TEST_ASSERT_EQUAL_DOUBLE(-700, in.command().aim_nm.y);
    TEST_ASSERT_FALSE(in.command().engaged);
    // the edge of the field and a scan as large as it are taken
    p.say("SCAN 1000 -1000 2000\n");
    in.poll();
    TEST_ASSERT_EQUAL(1, in.scans_asked());
}

void test_hand_lines_still_refused_as_before()
{
    const afm::Scene s = scene_from_text(kScene);
    Pipe p;
    afm::HandInput in(s, p.r);
    p.say("HAND 0 0 0 1\nHAND 0 0 5 2\nHAND 1001 0 5 1\nHAND 0 0 1000.5 0\n" + std::string(300, 'x') + "\nHAND 5 5 5 0\n");
    in.poll();
    TEST_ASSERT_EQUAL(5, in.refused());
    TEST_ASSERT_EQUAL(1, in.taken());
    TEST_ASSERT_EQUAL_DOUBLE(5, in.command().aim_nm.x);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_hand_and_scan_commands_are_taken);
    RUN_TEST(test_bad_scans_are_refused_and_counted);
    RUN_TEST(test_hand_lines_still_refused_as_before);
    return UNITY_END();
}
