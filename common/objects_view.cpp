#include "objects_view.hpp"

#include <algorithm>
#include <cmath>

namespace afm {

namespace {

// Below this an object has not moved (nm): the drift taken off and put back
// in doubles leaves a few units in the last place.
constexpr double kSame_nm = 1e-9;

bool same_particle(const particle_t &a, const particle_t &b, double dx, double dy)
{
    return a.id == b.id && a.in_contact == b.in_contact && a.radius_nm == b.radius_nm && std::fabs(b.x_nm - a.x_nm - dx) <= kSame_nm &&
           std::fabs(b.y_nm - a.y_nm - dy) <= kSame_nm;
}

bool same_wire(const wire_t &a, const wire_t &b, double dx, double dy)
{
    if (a.id != b.id || a.n != b.n || a.in_contact != b.in_contact || a.diameter_nm != b.diameter_nm) return false;
    for (int i = 0; i < a.n; ++i)
        if (std::fabs(b.x_nm[i] - a.x_nm[i] - dx) > kSame_nm || std::fabs(b.y_nm[i] - a.y_nm[i] - dy) > kSame_nm) return false;
    return true;
}

bool same_ids(const objects_t &a, const objects_t &b)
{
    if (a.particles.size() != b.particles.size() || a.wires.size() != b.wires.size()) return false;
    for (std::size_t i = 0; i < a.particles.size(); ++i)
        if (a.particles[i].id != b.particles[i].id) return false;
    for (std::size_t i = 0; i < a.wires.size(); ++i)
        if (a.wires[i].id != b.wires[i].id) return false;
    return true;
}

}  // namespace

objects_t ObjectsDiff::next(const objects_t &whole, bool force_complete)
{
    objects_t m = whole;
    m.complete = force_complete || !have_last_ || !same_ids(last_, whole) ||
                 whole.seq - last_complete_seq_ >= objects_t::KEYFRAME_BLOCKS || whole.seq < last_complete_seq_;
    m.base_seq = last_.seq;
    m.base_fix_id = last_.fix_id;
    if (!m.complete) {
        const double dx = whole.drift_nm[0] - last_.drift_nm[0], dy = whole.drift_nm[1] - last_.drift_nm[1];
        m.particles.clear();
        for (std::size_t i = 0; i < whole.particles.size(); ++i)
            if (!same_particle(last_.particles[i], whole.particles[i], dx, dy)) m.particles.push_back(whole.particles[i]);
        m.wires.clear();
        for (std::size_t i = 0; i < whole.wires.size(); ++i)
            if (!same_wire(last_.wires[i], whole.wires[i], dx, dy)) m.wires.push_back(whole.wires[i]);
    } else {
        last_complete_seq_ = whole.seq;
    }
    m.n_particles = static_cast<int32_t>(m.particles.size());
    m.n_wires = static_cast<int32_t>(m.wires.size());
    last_ = whole;
    have_last_ = true;
    return m;
}

ObjectsView::Take ObjectsView::apply(const objects_t &m, const Placed &placed)
{
    // A resend of the message last applied, or of an older one: nothing new.
    if (ready_ && key_of(m) <= key_of(whole_)) return Take::applied;
    if (m.complete) {
        whole_ = m;
        ready_ = true;
        if (placed) placed(m);
        drain(placed);
        return Take::applied;
    }
    if (!ready_ || base_of(m) != key_of(whole_)) {
        // Its base is still to come (the bus reordered them; before the
        // first complete message, every base is): keep it. A base older than
        // the set: one was missed, and the set waits for the next complete
        // message.
        if (ready_ && base_of(m) < key_of(whole_)) return Take::refused;
        for (const auto &h : held_)
            if (key_of(h) == key_of(m)) return Take::held;   // a resend of one kept
        if (held_.size() == kMaxHeld) {
            // Full: the newest of them and m is let go (the oldest are the
            // next the set can place).
            const auto newest = std::max_element(held_.begin(), held_.end(),
                                                 [](const objects_t &a, const objects_t &b) { return key_of(a) < key_of(b); });
            if (key_of(*newest) <= key_of(m)) return Take::refused;
            held_.erase(newest);
        }
        held_.push_back(m);
        return Take::held;
    }
    if (!place(m)) return Take::refused;
    if (placed) placed(m);
    drain(placed);
    return Take::applied;
}

void ObjectsView::drain(const Placed &placed)
{
    for (bool more = true; more;) {
        more = false;
        for (auto it = held_.begin(); it != held_.end();) {
            if (key_of(*it) <= key_of(whole_)) {
                it = held_.erase(it);   // made old by what came since
            } else if (base_of(*it) == key_of(whole_)) {
                const objects_t m = std::move(*it);
                held_.erase(it);
                if (place(m) && placed) placed(m);   // one that cannot be placed is let go
                more = true;            // each turn takes one away: it ends
                break;
            } else {
                ++it;
            }
        }
    }
}

bool ObjectsView::place(const objects_t &m)
{
    // Every listed object must be one the set holds.
    for (const auto &p : m.particles) {
        bool known = false;
        for (const auto &q : whole_.particles) known = known || q.id == p.id;
        if (!known) return false;
    }
    for (const auto &w : m.wires) {
        bool known = false;
        for (const auto &q : whole_.wires) known = known || q.id == w.id;
        if (!known) return false;
    }
    const double dx = m.drift_nm[0] - whole_.drift_nm[0], dy = m.drift_nm[1] - whole_.drift_nm[1];
    for (auto &q : whole_.particles) {
        q.x_nm += dx;
        q.y_nm += dy;
        for (const auto &p : m.particles)
            if (p.id == q.id) q = p;
    }
    for (auto &q : whole_.wires) {
        for (int i = 0; i < q.n; ++i) {
            q.x_nm[i] += dx;
            q.y_nm[i] += dy;
        }
        for (const auto &w : m.wires)
            if (w.id == q.id) q = w;
    }
    whole_.utime = m.utime;
    whole_.seq = m.seq;
    whole_.trenches = m.trenches;
    whole_.n_trenches = m.n_trenches;
    whole_.drift_nm[0] = m.drift_nm[0];
    whole_.drift_nm[1] = m.drift_nm[1];
    whole_.fix_id = m.fix_id;
    whole_.complete = true;
    return true;
}

}  // namespace afm
