// Unity tests of objects as whole sets on the bus (common/objects_view):
// what a publisher sends (only what changed, complete ones first, after a
// forced one and every KEYFRAME_BLOCKS) read back whole by a reader, with
// drift moving everything between messages; resends; a missed message
// noticed, and the reader whole again at the next complete one; messages
// handed over out of order held until their base comes (at most kMaxHeld).
#include <unity.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "objects_view.hpp"

namespace {

using Take = afm::ObjectsView::Take;

afm::particle_t particle(int id, double x, double y)
{
    afm::particle_t p{};
    p.id = id;
    p.x_nm = x;
    p.y_nm = y;
    p.radius_nm = 50;
    return p;
}

afm::objects_t whole(int64_t seq, int n)
{
    afm::objects_t o{};
    o.seq = seq;
    o.complete = true;
    for (int i = 0; i < n; ++i) o.particles.push_back(particle(i + 1, 100.0 * i, -50.0 * i));
    o.n_particles = n;
    afm::wire_t w{};
    w.id = 7;
    w.diameter_nm = 100;
    w.n = 2;
    w.x_nm = {0, 1000};
    w.y_nm = {0, 0};
    o.wires.push_back(w);
    o.n_wires = 1;
    return o;
}

void assert_same(const afm::objects_t &a, const afm::objects_t &b)
{
    TEST_ASSERT_EQUAL(a.particles.size(), b.particles.size());
    for (std::size_t i = 0; i < a.particles.size(); ++i) {
        TEST_ASSERT_EQUAL_INT(a.particles[i].id, b.particles[i].id);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, a.particles[i].x_nm, b.particles[i].x_nm);
        TEST_ASSERT_DOUBLE_WITHIN(1e-9, a.particles[i].y_nm, b.particles[i].y_nm);
        TEST_ASSERT_EQUAL(a.particles[i].in_contact, b.particles[i].in_contact);
    }
    TEST_ASSERT_EQUAL(a.wires.size(), b.wires.size());
    for (std::size_t i = 0; i < a.wires.size(); ++i)
        for (int k = 0; k < a.wires[i].n; ++k) TEST_ASSERT_DOUBLE_WITHIN(1e-9, a.wires[i].x_nm[k], b.wires[i].x_nm[k]);
    TEST_ASSERT_DOUBLE_WITHIN(0, a.drift_nm[0], b.drift_nm[0]);
}

}  // namespace

void setUp() {}
void tearDown() {}

void test_round_trip_with_moves_and_drift()
{
    afm::ObjectsDiff diff;
    afm::ObjectsView view;
    afm::objects_t w = whole(0, 50);
    std::mt19937_64 gen(12345);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    auto rnd = [&] { return uni(gen); };
    int complete = 0;
    std::size_t listed = 0;
    for (int64_t n = 0; n < 1000; ++n) {
        w.seq = n;
        // drift moves everything a little; one particle is pushed
        const double dx = 0.01 * rnd(), dy = -0.02 * rnd();
        w.drift_nm[0] += dx;
        w.drift_nm[1] += dy;
        for (auto &p : w.particles) p.x_nm += dx, p.y_nm += dy;
        for (int k = 0; k < 2; ++k) w.wires[0].x_nm[k] += dx, w.wires[0].y_nm[k] += dy;
        auto &p = w.particles[static_cast<std::size_t>(n / 20 % 50)];
        p.x_nm += 1.5;
        p.in_contact = n % 3 == 0;
        const afm::objects_t m = diff.next(w);
        complete += m.complete;
        if (!m.complete) listed += m.particles.size();
        TEST_ASSERT_TRUE(view.apply(m) == Take::applied);
        assert_same(w, view.whole());
        // a resend of the same message changes nothing
        TEST_ASSERT_TRUE(view.apply(m) == Take::applied);
        assert_same(w, view.whole());
    }
    TEST_ASSERT_EQUAL_INT(1000 / afm::objects_t::KEYFRAME_BLOCKS, complete);
    TEST_ASSERT_TRUE(listed <= 990);   // the one pushed, not the fifty drifting
}

void test_forced_and_count_changes_are_complete()
{
    afm::ObjectsDiff diff;
    afm::objects_t w = whole(0, 3);
    TEST_ASSERT_TRUE(diff.next(w).complete);
    w.seq = 1;
    const afm::objects_t quiet = diff.next(w);
    TEST_ASSERT_FALSE(quiet.complete);
    TEST_ASSERT_EQUAL_INT(0, quiet.n_particles);
    TEST_ASSERT_EQUAL_INT(0, quiet.n_wires);
    TEST_ASSERT_TRUE(diff.next(w, true).complete);   // a fix's answer
    w.seq = 2;
    w.particles.pop_back();
    w.n_particles = 2;
    TEST_ASSERT_TRUE(diff.next(w).complete);          // the set changed
    w.seq = 1;                                        // back in time (a fresh start)
    TEST_ASSERT_TRUE(diff.next(w).complete);
}

void test_reader_refuses_what_it_cannot_place()
{
    afm::ObjectsView view;
    afm::objects_t m = whole(5, 3);
    m.complete = false;
    TEST_ASSERT_TRUE(view.apply(m) == Take::held);   // changes before any whole set: kept for its base
    TEST_ASSERT_FALSE(view.ready());
    m.complete = true;
    TEST_ASSERT_TRUE(view.apply(m) == Take::applied);
    TEST_ASSERT_EQUAL_UINT(0, view.held());           // of the same block as the set: old
    afm::objects_t odd = whole(6, 0);
    odd.complete = false;
    odd.particles.push_back(particle(99, 0, 0));   // an id the set does not hold
    odd.n_particles = 1;
    TEST_ASSERT_TRUE(view.apply(odd) == Take::refused);
    TEST_ASSERT_EQUAL_INT(5, static_cast<int>(view.whole().seq));
}

void test_a_missed_message_is_noticed_and_healed_by_the_next_complete()
{
    afm::ObjectsDiff diff;
    afm::ObjectsView view;
    afm::objects_t w = whole(0, 5);
    TEST_ASSERT_TRUE(view.apply(diff.next(w)) == Take::applied);
    w.seq = 1;
    w.particles[2].x_nm += 7;
    const afm::objects_t lost = diff.next(w);   // never reaches the reader
    TEST_ASSERT_FALSE(lost.complete);
    w.seq = 2;
    w.particles[3].y_nm += 3;
    const afm::objects_t after = diff.next(w);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(after.base_seq));
    // It follows a message the reader does not hold: kept for that base,
    // which never comes; the set stays the last one placed.
    TEST_ASSERT_TRUE(view.apply(after) == Take::held);
    TEST_ASSERT_TRUE(view.ready());
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(view.whole().seq));
    w.seq = 3;
    TEST_ASSERT_TRUE(view.apply(diff.next(w)) == Take::held);
    TEST_ASSERT_EQUAL_UINT(2, view.held());
    // Whole again at the next complete message, which makes the held old.
    TEST_ASSERT_TRUE(view.apply(diff.next(w, true)) == Take::applied);
    assert_same(w, view.whole());
    TEST_ASSERT_EQUAL_UINT(0, view.held());
    // An older message arriving late changes nothing.
    TEST_ASSERT_TRUE(view.apply(lost) == Take::applied);
    assert_same(w, view.whole());
}

// A base older than the set (a fix's answer came between): cannot be placed.
void test_a_change_on_an_older_base_is_refused()
{
    afm::ObjectsDiff diff;
    afm::ObjectsView view;
    afm::objects_t w = whole(0, 3);
    TEST_ASSERT_TRUE(view.apply(diff.next(w)) == Take::applied);
    w.seq = 1;
    afm::objects_t m = diff.next(w);
    m.base_seq = -1;
    TEST_ASSERT_TRUE(view.apply(m) == Take::refused);
    TEST_ASSERT_EQUAL_UINT(0, view.held());
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(view.whole().seq));
}

// The kernel holds a datagram back behind the next one (faults/faults.py,
// net:kernel): block n+1's changes come before block n's. Both are placed
// when n comes, in turn; a resend of the held one is not kept twice.
void test_a_message_before_its_base_is_held_until_the_base_comes()
{
    afm::ObjectsDiff diff;
    afm::ObjectsView view;
    afm::objects_t w = whole(0, 5);
    TEST_ASSERT_TRUE(view.apply(diff.next(w)) == Take::applied);
    w.seq = 1;
    w.particles[1].x_nm += 4;
    w.drift_nm[0] += 0.5;
    for (auto &p : w.particles) p.x_nm += 0.5;
    const afm::objects_t first = diff.next(w);
    w.seq = 2;
    w.particles[2].y_nm -= 6;
    const afm::objects_t second = diff.next(w);
    TEST_ASSERT_FALSE(second.complete);
    TEST_ASSERT_TRUE(view.apply(second) == Take::held);
    TEST_ASSERT_TRUE(view.apply(second) == Take::held);   // resent
    TEST_ASSERT_EQUAL_UINT(1, view.held());
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(view.whole().seq));
    TEST_ASSERT_TRUE(view.apply(first) == Take::applied);
    TEST_ASSERT_EQUAL_INT(2, static_cast<int>(view.whole().seq));
    TEST_ASSERT_EQUAL_UINT(0, view.held());
    assert_same(w, view.whole());
    // Now both are old.
    TEST_ASSERT_TRUE(view.apply(second) == Take::applied);
    TEST_ASSERT_TRUE(view.apply(first) == Take::applied);
    assert_same(w, view.whole());
}

// Many blocks before their base: at most kMaxHeld are kept, the newest let
// go first (the oldest are the next the set can place); when the base comes
// the set moves as far as the chain holds, and the rest come as resends.
void test_at_most_kmaxheld_are_held_and_the_chain_is_placed_as_far_as_it_goes()
{
    afm::ObjectsDiff diff;
    afm::ObjectsView view;
    afm::objects_t w = whole(0, 4);
    TEST_ASSERT_TRUE(view.apply(diff.next(w)) == Take::applied);
    const int64_t last = static_cast<int64_t>(afm::ObjectsView::kMaxHeld) + 3;
    std::vector<afm::objects_t> sent(1);   // sent[n]: block n's message
    for (int64_t n = 1; n <= last; ++n) {
        w.seq = n;
        w.particles[static_cast<std::size_t>(n % 4)].x_nm += 1.0 * static_cast<double>(n);
        sent.push_back(diff.next(w));
    }
    // Blocks last .. 2, newest first: the first kMaxHeld are held, then each
    // older one takes the place of the newest held.
    for (int64_t n = last; n >= 2; --n) TEST_ASSERT_TRUE(view.apply(sent[static_cast<std::size_t>(n)]) == Take::held);
    TEST_ASSERT_EQUAL_UINT(afm::ObjectsView::kMaxHeld, view.held());
    // Full, and newer than every one held: let go.
    TEST_ASSERT_TRUE(view.apply(sent[static_cast<std::size_t>(last)]) == Take::refused);
    TEST_ASSERT_EQUAL_INT(0, static_cast<int>(view.whole().seq));
    // Block 1: the chain 1 .. kMaxHeld + 1 is placed.
    TEST_ASSERT_TRUE(view.apply(sent[1]) == Take::applied);
    TEST_ASSERT_EQUAL_INT(static_cast<int>(afm::ObjectsView::kMaxHeld) + 1, static_cast<int>(view.whole().seq));
    TEST_ASSERT_EQUAL_UINT(0, view.held());
    // The two let go come again (the card resends): the set is whole.
    TEST_ASSERT_TRUE(view.apply(sent[static_cast<std::size_t>(last - 1)]) == Take::applied);
    TEST_ASSERT_TRUE(view.apply(sent[static_cast<std::size_t>(last)]) == Take::applied);
    assert_same(w, view.whole());
}

// The first block's complete message comes after the second block's
// changes (seen under net:kernel: the renderer then waited for a keyframe
// while the simulator waited for its frame): both are placed.
void test_changes_before_the_first_complete_are_placed_when_it_comes()
{
    afm::ObjectsDiff diff;
    afm::ObjectsView view;
    afm::objects_t w = whole(0, 3);
    const afm::objects_t first = diff.next(w);
    w.seq = 1;
    w.particles[0].x_nm += 2;
    const afm::objects_t second = diff.next(w);
    TEST_ASSERT_TRUE(first.complete);
    TEST_ASSERT_FALSE(second.complete);
    TEST_ASSERT_TRUE(view.apply(second) == Take::held);
    TEST_ASSERT_FALSE(view.ready());
    TEST_ASSERT_TRUE(view.apply(first) == Take::applied);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(view.whole().seq));
    assert_same(w, view.whole());
}

// A held message naming an object the set does not hold is let go when its
// base comes; the base is placed.
void test_a_held_message_that_cannot_be_placed_is_let_go()
{
    afm::ObjectsDiff diff;
    afm::ObjectsView view;
    afm::objects_t w = whole(0, 3);
    TEST_ASSERT_TRUE(view.apply(diff.next(w)) == Take::applied);
    w.seq = 1;
    const afm::objects_t base = diff.next(w);
    w.seq = 2;
    afm::objects_t odd = diff.next(w);
    odd.particles.push_back(particle(99, 0, 0));
    odd.n_particles = static_cast<int32_t>(odd.particles.size());
    TEST_ASSERT_TRUE(view.apply(odd) == Take::held);
    TEST_ASSERT_TRUE(view.apply(base) == Take::applied);
    TEST_ASSERT_EQUAL_INT(1, static_cast<int>(view.whole().seq));
    TEST_ASSERT_EQUAL_UINT(0, view.held());
}

// The reader tells of each message as it is placed, in the order placed
// (the Python log reader builds its blocks from this: objects_view_c.h):
// a held chain after its base, a resend and a refused one not at all, one
// let go from the held list not at all.
void test_each_message_placed_is_told_in_order_with_the_set_after_it()
{
    afm::ObjectsDiff diff;
    afm::ObjectsView view;
    std::vector<std::pair<int64_t, int64_t>> told;   // (the message's seq, the set's seq then)
    const afm::ObjectsView::Placed tell = [&](const afm::objects_t &m) { told.emplace_back(m.seq, view.whole().seq); };
    afm::objects_t w = whole(0, 3);
    std::vector<afm::objects_t> sent;
    sent.push_back(diff.next(w));
    for (int64_t n = 1; n <= 4; ++n) {
        w.seq = n;
        w.particles[static_cast<std::size_t>(n % 3)].x_nm += 3;
        sent.push_back(diff.next(w));
    }
    afm::objects_t odd = sent[4];
    odd.particles.push_back(particle(99, 0, 0));
    odd.n_particles = static_cast<int32_t>(odd.particles.size());
    TEST_ASSERT_TRUE(view.apply(sent[2], tell) == Take::held);   // before the first complete one
    TEST_ASSERT_TRUE(view.apply(sent[3], tell) == Take::held);
    TEST_ASSERT_TRUE(view.apply(odd, tell) == Take::held);       // cannot be placed: let go when its turn comes
    TEST_ASSERT_TRUE(told.empty());
    TEST_ASSERT_TRUE(view.apply(sent[0], tell) == Take::applied);
    TEST_ASSERT_EQUAL_UINT(1, told.size());                      // 1 is still to come
    TEST_ASSERT_TRUE(view.apply(sent[1], tell) == Take::applied);
    const std::vector<std::pair<int64_t, int64_t>> want = {{0, 0}, {1, 1}, {2, 2}, {3, 3}};
    TEST_ASSERT_TRUE(told == want);
    TEST_ASSERT_EQUAL_UINT(0, view.held());
    TEST_ASSERT_TRUE(view.apply(sent[2], tell) == Take::applied);  // a resend: nothing new
    TEST_ASSERT_TRUE(view.apply(odd, tell) == Take::refused);
    TEST_ASSERT_TRUE(told == want);
    TEST_ASSERT_TRUE(view.apply(sent[4], tell) == Take::applied);
    TEST_ASSERT_EQUAL_UINT(5, told.size());
    assert_same(w, view.whole());
}

int main()
{
    UNITY_BEGIN();
    RUN_TEST(test_round_trip_with_moves_and_drift);
    RUN_TEST(test_forced_and_count_changes_are_complete);
    RUN_TEST(test_reader_refuses_what_it_cannot_place);
    RUN_TEST(test_a_missed_message_is_noticed_and_healed_by_the_next_complete);
    RUN_TEST(test_a_change_on_an_older_base_is_refused);
    RUN_TEST(test_a_message_before_its_base_is_held_until_the_base_comes);
    RUN_TEST(test_at_most_kmaxheld_are_held_and_the_chain_is_placed_as_far_as_it_goes);
    RUN_TEST(test_changes_before_the_first_complete_are_placed_when_it_comes);
    RUN_TEST(test_a_held_message_that_cannot_be_placed_is_let_go);
    RUN_TEST(test_each_message_placed_is_told_in_order_with_the_set_after_it);
    return UNITY_END();
}
