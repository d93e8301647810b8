// The renderer's decisions (renderer/renderer.hpp), without a bus (LCM's
// memq:// provider): which frames the contact sheet takes, a block's
// messages refused when they cannot be the block they claim, the card's
// force kept by block so that a frame shows its own block, blocks whose
// objects never came counted as missed (and not when they came late), and
// the run's frames cut when the simulator says the run ends early.
#include <lcm/lcm-cpp.hpp>

#include "lockstep.hpp"
#include "renderer.hpp"

#include "../scene_text.hpp"

using afm::render::BySeq;
using afm::render::Renderer;

void setUp() {}
void tearDown() {}

static const char *kScene =
    "name: t\nseed: 1\nduration_s: 2\nblock_hz: 1000\nsample_rate_hz: 20000\nframe_rate_hz: 25\n"
    "sample: {substrate: glass, field_nm: 2000}\n"
    "objects: {particles: [{id: 1, x_nm: 0, y_nm: 0, radius_nm: 50}]}\n"
    "operator: {load_nN: 5, speed_nm_per_s: 2000, path_nm: [[0, -700], [0, -90]]}\n"
    "outputs: {image_px: 64, contact_sheet_frames: 4}\n";

struct Fixture {
    afm::Scene scene = scene_from_text(kScene);
    lcm::LCM lc{"memq://"};
    afm::Heartbeat hb{lc, "renderer"};
    Renderer r{scene, lc, hb, "/nonexistent-not-written"};
};

void test_the_contact_sheet_takes_frames_evenly_from_first_to_last()
{
    Fixture f;
    TEST_ASSERT_EQUAL(50, f.r.total_frames);
    const std::vector<int> want = {0, 16, 33, 49};
    TEST_ASSERT_EQUAL(want.size(), f.r.sheet_at.size());
    for (std::size_t i = 0; i < want.size(); ++i) TEST_ASSERT_EQUAL(want[i], f.r.sheet_at[i]);
}

void test_a_block_message_is_refused_when_it_cannot_be_that_block()
{
    Fixture f;
    const int64_t end3 = afm::block_end_utime(f.scene, 3);
    TEST_ASSERT_EQUAL(static_cast<int>(afm::Reject::none), static_cast<int>(f.r.block_message(3, end3)));
    // its time must be its block's end
    TEST_ASSERT_EQUAL(static_cast<int>(afm::Reject::out_of_range), static_cast<int>(f.r.block_message(3, end3 + 1)));
    TEST_ASSERT_EQUAL(static_cast<int>(afm::Reject::out_of_range), static_cast<int>(f.r.block_message(-2, 0)));
    // no more than a simulated second (and two blocks) past the last block taken
    TEST_ASSERT_EQUAL(static_cast<int>(afm::Reject::seq_future),
                      static_cast<int>(f.r.block_message(2000, afm::block_end_utime(f.scene, 2000))));
}

void test_a_frame_shows_the_force_of_its_own_block()
{
    BySeq<afm::haptic_force_t> hands;
    for (int64_t s : {0, 1, 2, 5}) {
        afm::haptic_force_t m{};
        m.seq = s;
        m.force_N[0] = static_cast<double>(s);
        TEST_ASSERT_EQUAL(static_cast<int>(afm::Reject::none), static_cast<int>(hands.put(m)));
    }
    afm::haptic_force_t old{};
    old.seq = 4;   // older than the newest: refused, the newest kept
    TEST_ASSERT_EQUAL(static_cast<int>(afm::Reject::seq_past), static_cast<int>(hands.put(old)));
    TEST_ASSERT_EQUAL_DOUBLE(1.0, hands.at(1).force_N[0]);
    TEST_ASSERT_EQUAL_DOUBLE(2.0, hands.at(3).force_N[0]);   // the latest up to block 3
    TEST_ASSERT_EQUAL_DOUBLE(5.0, hands.at(9).force_N[0]);
    TEST_ASSERT_EQUAL(-1, hands.at(-5).seq);   // before the first: none
}

void test_blocks_whose_objects_never_came_are_missed_and_late_ones_are_not()
{
    Fixture f;
    f.r.count_objects_block(0);
    f.r.count_objects_block(1);
    f.r.count_objects_block(5);   // 2, 3 and 4 skipped
    TEST_ASSERT_EQUAL(3, f.r.objects_missed());
    f.r.count_objects_block(3);   // came late, after 5
    TEST_ASSERT_EQUAL(2, f.r.objects_missed());
}

void test_the_simulators_early_end_cuts_the_frames_and_picks_the_sheet_again()
{
    Fixture f;
    afm::heartbeat_t m{};
    m.name = "sim_afm";
    m.state = afm::state_text(afm::RunState::ending);
    m.seq = 599;   // the run ends after block 599, at 0.6 s: frames 0 to 15 (frame k at k / 25 s)
    f.r.on_heartbeat(m);
    TEST_ASSERT_EQUAL(16, f.r.total_frames);
    TEST_ASSERT_EQUAL(15, f.r.sheet_at.back());
    TEST_ASSERT_FALSE(f.r.sim_done);
    m.name = "launcher";   // another process saying "ending" is not the simulator
    m.seq = 99;
    f.r.on_heartbeat(m);
    TEST_ASSERT_EQUAL(16, f.r.total_frames);
    m.name = "sim_afm";
    m.state = afm::state_text(afm::RunState::done);
    f.r.on_heartbeat(m);
    TEST_ASSERT_TRUE(f.r.sim_done);
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_the_contact_sheet_takes_frames_evenly_from_first_to_last);
    RUN_TEST(test_a_block_message_is_refused_when_it_cannot_be_that_block);
    RUN_TEST(test_a_frame_shows_the_force_of_its_own_block);
    RUN_TEST(test_blocks_whose_objects_never_came_are_missed_and_late_ones_are_not);
    RUN_TEST(test_the_simulators_early_end_cuts_the_frames_and_picks_the_sheet_again);
    return UNITY_END();
}
