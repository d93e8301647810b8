// Objects on the bus as whole sets: messages that list only what changed
// (objects_t.complete false, lcmtypes/objects_t.lcm) written by a publisher
// and read back whole by a reader.
#pragma once

#include <cstdint>

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

// The reader's side: the whole set after each message.
class ObjectsView {
public:
    // Applies a message. A changes-only message before any complete one,
    // naming an object the set does not hold, or following a message this
    // reader does not hold (one was missed: base_seq, base_fix_id), is not
    // applied: false, and after a missed one the reader is not ready until
    // the next complete message. A resend of the message last applied (or
    // of an older one) changes nothing and is taken as applied.
    bool apply(const objects_t &m);
    bool ready() const { return ready_; }
    const objects_t &whole() const { return whole_; }   // complete, in the publisher's order

private:
    objects_t whole_{};
    bool ready_ = false;
};

}  // namespace afm
