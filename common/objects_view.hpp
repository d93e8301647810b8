// Objects on the bus as whole sets: messages that list only what changed
// (objects_t.complete false, lcmtypes/objects_t.lcm) written by a publisher
// and read back whole by a reader.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "afm/objects_t.hpp"

namespace afm {

// The publisher's side: from each block's whole set, the message to send.
class ObjectsDiff {
public:
    // The message for `whole` (complete, with every object): complete when
    // `force_complete`, for the first message, when the objects' count or
    // ids changed, or KEYFRAME_BLOCKS after the last complete one;
    // otherwise only the objects that changed other than by the drift.
    objects_t next(const objects_t &whole, bool force_complete = false);

private:
    objects_t last_{};          // the whole set of the last message sent
    bool have_last_ = false;
    int64_t last_complete_seq_ = 0;
};

// The order of objects messages: by block, then by fix (a fix's answer
// follows its block's message). Where a message stands, and where the one
// it follows (its base) stood.
using ObjectsKey = std::pair<int64_t, int32_t>;
inline ObjectsKey key_of(const objects_t &m) { return {m.seq, m.fix_id}; }
inline ObjectsKey base_of(const objects_t &m) { return {m.base_seq, m.base_fix_id}; }

// The reader's side: the whole set after each message.
//
// The bus may hand a reader two messages out of order (the kernel holds a
// datagram back behind the next one: faults/faults.py, net:kernel; the first
// block's complete message may come after the second's changes). A
// changes-only message whose base is newer than the set held, or that comes
// before any complete message, is kept (at
// most kMaxHeld: past that the newest is let go, as the oldest are the next
// the set can place) and applied as soon as its base has been: the set then
// jumps to the newest message it can place.
//
// This is the one reader of objects messages: the renderer and the
// operator use it directly, and the Python log reader (tools/afmlog.py)
// through objects_view_c.h, so a log reads as the bus's processes read it.
class ObjectsView {
public:
    enum class Take {
        applied,   // the set now includes the message (or a later one: a resend, an old message)
        held,      // kept until its base comes (or a complete message makes it old)
        refused,   // cannot be placed: an id the set does not hold, a base older than the set
                   // (one was missed: the next complete one heals), or newer than all kMaxHeld held
    };
    static constexpr std::size_t kMaxHeld = objects_t::MAX_HELD;
    // Told of each message as it is placed in the set (whole() is then the
    // set after it): m itself, then each held message it lets follow, in turn.
    using Placed = std::function<void(const objects_t &placed)>;

    Take apply(const objects_t &m, const Placed &placed = nullptr);
    bool ready() const { return ready_; }                 // a complete message has come
    const objects_t &whole() const { return whole_; }     // complete, in the publisher's order
    std::size_t held() const { return held_.size(); }     // messages kept for their base

private:
    bool place(const objects_t &m);              // a changes-only message that follows: applied, or false
    void drain(const Placed &placed);            // the held messages that now follow, in turn

    objects_t whole_{};
    bool ready_ = false;
    std::vector<objects_t> held_;
};
}  // namespace afm
