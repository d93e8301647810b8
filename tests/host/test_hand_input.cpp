// The page's hand pipe (operator/hand_input.hpp), without a run: lines
// written to a real pipe, read by poll(). HAND sets the hand's command; SCAN
// asks for a local scan, taken once (the newest); PUSH asks for a planner
// stroke, taken once (the newest); a line that is none of them, or out of
// the field or range, is refused, counted by its reason, and changes
// nothing; while a stroke drives the tip, HAND lines are held.
#include <unistd.h>

#include <cmath>
#include <cstdio>
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
        "PUSH 1 0 0\n",           // no particle 1 in this scene
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

// The same field with two particles (ids 3 and 7, radius 50 nm).
static const char *kScenePush =
    "name: t\nseed: 1\nduration_s: 1\ntime_mode: realtime\nsample: {substrate: glass, field_nm: 2000}\n"
    "objects:\n  particles:\n    - {id: 3, x_nm: 0, y_nm: -300, radius_nm: 50}\n    - {id: 7, x_nm: 400, y_nm: 0, radius_nm: 50}\n"
    "operator:\n  mode: browser\n  load_nN: 5\n  path_nm: [[0, -700]]\noutputs: {image_px: 128, video: none}\n";

void test_push_commands_are_taken_once_newest_first()
{
    const afm::Scene s = scene_from_text(kScenePush);
    Pipe p;
    afm::HandInput in(s, p.r);
    afm::HandInput::PushAsk a{};
    TEST_ASSERT_FALSE(in.take_push(&a));
    p.say("PUSH 3 0 300\n");
    in.poll();
    TEST_ASSERT_EQUAL(1, in.pushes_asked());
    TEST_ASSERT_EQUAL(0, in.refused());
    TEST_ASSERT_TRUE(in.take_push(&a));
    TEST_ASSERT_EQUAL(3, a.id);
    TEST_ASSERT_EQUAL_DOUBLE(0, a.target_nm.x);
    TEST_ASSERT_EQUAL_DOUBLE(300, a.target_nm.y);
    TEST_ASSERT_FALSE(in.take_push(&a));   // taken once
    // the particle wholly inside the field: its centre 50 nm from the edge is taken
    p.say("PUSH 3 950 0\nPUSH 7 -950 950\n");
    in.poll();
    TEST_ASSERT_EQUAL(3, in.pushes_asked());
    TEST_ASSERT_TRUE(in.take_push(&a));
    TEST_ASSERT_EQUAL(7, a.id);
    TEST_ASSERT_EQUAL_DOUBLE(-950, a.target_nm.x);
    TEST_ASSERT_EQUAL(0, in.taken());   // a push is not the hand's command
}

struct BadLine {
    const char *line;
    const char *why;
    int src_line;
};

void test_bad_pushes_are_refused_with_their_reason()
{
    const afm::Scene s = scene_from_text(kScenePush);
    Pipe p;
    afm::HandInput in(s, p.r);
    const BadLine bad[] = {
        {"PUSH 4 0 300\n", "unknown particle", __LINE__},
        {"PUSH 0 0 300\n", "unknown particle", __LINE__},
        {"PUSH 3 1000 0\n", "target outside the field", __LINE__},      // on the edge: half the particle outside
        {"PUSH 3 0 -950.5\n", "target outside the field", __LINE__},
        {"PUSH 3 1e9 0\n", "target outside the field", __LINE__},
        {"PUSH 3 -1e308 -1e308\n", "target outside the field", __LINE__},
        {"PUSH 3 nan 0\n", "not a command", __LINE__},
        {"PUSH 3 0 inf\n", "not a command", __LINE__},
        {"PUSH -3 0 0\n", "not a command", __LINE__},
        {"PUSH 3.0 0 0\n", "not a command", __LINE__},
        {"PUSH 3e0 0 0\n", "not a command", __LINE__},
        {"PUSH 9999999999 0 0\n", "not a command", __LINE__},          // more digits than an id has
        {"PUSH x 0 0\n", "not a command", __LINE__},
        {"PUSH 3 0\n", "not a command", __LINE__},                     // a number missing
        {"PUSH 3 0 0 0\n", "not a command", __LINE__},                 // one too many
        {"PUSH 3 0 0x\n", "not a command", __LINE__},
        {"push 3 0 0\n", "not a command", __LINE__},
    };
    int n = 0;
    for (const BadLine &b : bad) {
        p.say(b.line);
        in.poll();
        char msg[120];
        std::snprintf(msg, sizeof msg, "row at line %d: %s", b.src_line, b.line);
        TEST_ASSERT_EQUAL_MESSAGE(++n, in.refused(), msg);
        const auto &r = in.refusals();
        int64_t total = 0;
        for (const auto &kv : r) total += kv.second;
        TEST_ASSERT_EQUAL_MESSAGE(n, total, msg);
    }
    TEST_ASSERT_EQUAL(2, in.refusals().at("unknown particle"));
    TEST_ASSERT_EQUAL(4, in.refusals().at("target outside the field"));
    TEST_ASSERT_EQUAL(11, in.refusals().at("not a command"));
    afm::HandInput::PushAsk a{};
    TEST_ASSERT_FALSE(in.take_push(&a));
    TEST_ASSERT_EQUAL(0, in.pushes_asked());
}

void test_hand_lines_are_held_while_a_stroke_runs()
{
    const afm::Scene s = scene_from_text(kScenePush);
    Pipe p;
    afm::HandInput in(s, p.r);
    p.say("HAND 10 -650 7.5 1\n");
    in.poll();
    in.yield(true);
    p.say("HAND 500 500 9 1\nHAND 600 600 9 1\n");
    in.poll();
    TEST_ASSERT_EQUAL(1, in.taken());
    TEST_ASSERT_EQUAL(2, in.held());
    TEST_ASSERT_EQUAL(0, in.refused());
    TEST_ASSERT_EQUAL_DOUBLE(10, in.command().aim_nm.x);   // the command before the stroke, untouched
    // the stroke ends with the tip lifted at (120, 80): the hand's target, lifted, the load kept
    in.hand_back({120, 80});
    TEST_ASSERT_EQUAL_DOUBLE(120, in.command().aim_nm.x);
    TEST_ASSERT_EQUAL_DOUBLE(80, in.command().aim_nm.y);
    TEST_ASSERT_FALSE(in.command().engaged);
    TEST_ASSERT_EQUAL_DOUBLE(7.5, in.command().load_nN);
    p.say("HAND 130 90 7.5 1\n");   // the hand's own again
    in.poll();
    TEST_ASSERT_EQUAL(2, in.taken());
    TEST_ASSERT_EQUAL_DOUBLE(130, in.command().aim_nm.x);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_hand_and_scan_commands_are_taken);
    RUN_TEST(test_bad_scans_are_refused_and_counted);
    RUN_TEST(test_hand_lines_still_refused_as_before);
    RUN_TEST(test_push_commands_are_taken_once_newest_first);
    RUN_TEST(test_bad_pushes_are_refused_with_their_reason);
    RUN_TEST(test_hand_lines_are_held_while_a_stroke_runs);
    return UNITY_END();
}
