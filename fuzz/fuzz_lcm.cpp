// Fuzz target "lcm": every bus message's decode-and-validate path, and the
// handlers behind it that need no bus.
//
// Input: the channel's name and a NUL, then the datagram (as LCM's own
// datagram names its channel: the committed seeds and crash inputs name
// theirs, whatever the order of lcmtypes/channels.yaml). An input that does
// not begin with the name of a channel of the bus (the fuzzer changed it)
// has its first byte pick one, modulo the number of channels, and the rest
// is the datagram: every input reaches a decoder. The datagram is handed to
// an afm::Inbox (bus/inbox.hpp) as if it had arrived on that channel. The
// inbox decodes it as the channel's type (the guarded decoder,
// decode_checked); what it refuses it names, and nothing else happens.
//
// What it takes must keep the decoder's promises: the message encodes again
// to exactly the bytes it was decoded from (lengths, strings and numbers as
// they came), and decodes from them to the same message. Then:
//  - AFM_ANALOG, HAPTIC_POSE, HOST_OBJECT_FIX go to a fresh firmware card
//    (afm::CardNode, host/card_node.hpp) on a small scene with
//    particles, a wire, a landmark and lithography: the block with a pose
//    for it (and its signals for 7 blocks more), the pose with a block of
//    zeros for it (and 7 more), the fix after block 0 and before block 1.
//    Everything the card publishes must itself pass the bus's decoder;
//  - FW_STATE's and SIM_TRUTH's objects go to an afm::ObjectsView holding
//    the card's first complete objects (objects_view.hpp), then, when the
//    view holds one for its base, that base; the whole set it then holds
//    must encode and decode cleanly.
// A broken promise aborts (a crash); so does a sanitizer's report.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "afm_channels.h"
#include "afm/heartbeat_t.hpp"
#include "afm/render_frame_t.hpp"
#include "afm/scan_line_t.hpp"
#include "afm/scan_req_t.hpp"
#include "afm/sim_truth_t.hpp"
#include "afm/view_frame_t.hpp"
#include "card_node.hpp"
#include "fuzz_files.hpp"
#include "inbox.hpp"
#include "objects_view.hpp"
#include "scene.hpp"

namespace afm {
namespace {

using afm_fuzz::broken;

// 4 samples per block: a block is 4 x 5 doubles on the wire.
const char kScene[] =
    "name: fuzz-card\n"
    "seed: 3\n"
    "duration_s: 1\n"
    "sample_rate_hz: 4000\n"
    "block_hz: 1000\n"
    "frame_rate_hz: 25\n"
    "effects: [bending_offset, adhesion, lithography]\n"
    "sample:\n"
    "  substrate: polycarbonate\n"
    "  field_nm: 4000\n"
    "  tip_substrate: {mu: 0.0865, adhesion_nN: 1.0}\n"
    "  particle_substrate: {mu: 0.3, adhesion_nN: 3.0}\n"
    "  lithography: {threshold_nN: 20, depth_nm_per_nN: 2}\n"
    "  wire: {friction_nN_per_um: 20}\n"
    "objects:\n"
    "  particles:\n"
    "    - {id: 1, x_nm: 0, y_nm: -300, radius_nm: 50}\n"
    "  wires:\n"
    "    - {id: 2, x0_nm: -650, y0_nm: 400, x1_nm: 650, y1_nm: 400, diameter_nm: 100}\n"
    "  landmarks:\n"
    "    - {id: 10, x_nm: -1400, y_nm: 1400, side_nm: 500, height_nm: 200}\n"
    "operator:\n"
    "  load_nN: 5\n"
    "  speed_nm_per_s: 2000\n"
    "  path_nm: [[0, -700], [0, -90]]\n"
    "outputs: {image_px: 64, video: none, png: false}\n";

const Scene &scene()
{
    static const Scene s = [] {
        afm_fuzz::Folder dir("lcm");
        return load_scene(dir.write("card.yaml", kScene));
    }();
    return s;
}

// Encodes m; checks the size it claims.
template <class M>
std::vector<uint8_t> encoded(const M &m)
{
    const int n = m.getEncodedSize();
    if (n < 8) broken("getEncodedSize below a fingerprint");
    std::vector<uint8_t> b(static_cast<std::size_t>(n));
    if (m.encode(b.data(), 0, n) != n) broken("encode wrote other than getEncodedSize bytes");
    return b;
}

// The decoder's promise for a message it took from data[0, size).
template <class M>
void check_taken(const M &m, const void *data, std::size_t size)
{
    const std::vector<uint8_t> e = encoded(m);
    if (e.size() > size) broken("a decoded message encodes longer than its datagram");
    if (std::memcmp(e.data(), data, e.size()) != 0) broken("a decoded message encodes to other bytes than it came from");
    M again;
    if (decode_checked(e.data(), e.size(), &again) != Reject::none) broken("a decoded message, encoded, is refused");
    if (encoded(again) != e) broken("decode(encode(m)) differs from m");
}

// Blocks a card runs on one block's signals or one pose.
constexpr int kBlocks = 8;

// What a fresh card makes of one message, and what it publishes.
class Card {
public:
    Card() : node_(scene()) {}

    void block(int64_t seq, const haptic_pose_t *pose = nullptr)
    {
        analog_block_t b{};
        b.seq = seq;
        b.utime = seq * 1000;
        b.fs_hz = scene().sample_rate_hz;
        b.n = scene().samples_per_block();
        for (auto *v : {&b.sn_v, &b.sl_v, &b.piezo_x_nm, &b.piezo_y_nm, &b.piezo_z_nm})
            v->assign(static_cast<std::size_t>(b.n), 0.0);
        b.piezo_y_nm.assign(static_cast<std::size_t>(b.n), -700.0);
        haptic_pose_t p = pose ? *pose : haptic_pose_t{};
        p.seq = seq;
        p.utime = b.utime;
        if (!pose) p.engaged = 1;
        check_out(node_.on_pose(p));
        check_out(node_.on_analog(b));
    }

    Reject analog(const analog_block_t &b)
    {
        Reject why = Reject::none;
        check_out(node_.on_analog(b, &why));
        if (why != Reject::none || b.seq != node_.done() + 1) return why;
        haptic_pose_t p{};
        p.seq = b.seq;
        p.engaged = 1;
        check_out(node_.on_pose(p));
        check_out(node_.on_analog(b));   // a resend: the same answers again
        // the same signals again: the card's state runs on (theta's window, lithography, pushes)
        for (int k = 1; k < kBlocks; ++k) {
            analog_block_t next = b;
            next.seq = b.seq + k;
            p.seq = next.seq;
            check_out(node_.on_pose(p));
            check_out(node_.on_analog(next));
        }
        return why;
    }

    Reject pose(const haptic_pose_t &p)
    {
        Reject why = Reject::none;
        check_out(node_.on_pose(p, &why));
        if (why != Reject::none) return why;
        for (int k = 0; k < kBlocks; ++k) block(node_.done() + 1, &p);
        return why;
    }

    Reject fix(const object_fix_t &f)
    {
        block(0);
        std::string note;
        Reject why = Reject::none;
        check_out(node_.on_fix(f, &note, &why));
        if (why == Reject::none) block(1);
        return why;
    }

    // The first complete objects the card publishes (FW_STATE after block 0).
    objects_t first_objects()
    {
        block(0);
        for (const auto &o : last_)
            if (o.channel == AFM_CH_FW_STATE) {
                fw_state_t m;
                if (decode_checked(o.data.data(), o.data.size(), &m) != Reject::none) broken("the card's FW_STATE is refused");
                return m.objects;
            }
        broken("block 0 published no FW_STATE");
    }

private:
    CardNode node_;
    Outbox last_;

    template <class M>
    static void check_posted(const Outgoing &o)
    {
        M m;
        if (decode_checked(o.data.data(), o.data.size(), &m) != Reject::none) broken("the card published a message the bus refuses");
    }

    void check_out(Outbox box)
    {
        for (const auto &o : box) {
            bool known = false;
#define AFM_CHECK(CH, T)                    \
    if (o.channel == #CH) {                 \
        check_posted<T>(o);                 \
        known = true;                       \
    }
            AFM_CHANNEL_TYPES(AFM_CHECK)
#undef AFM_CHECK
            if (!known) broken("the card published on a channel not in channels.yaml");
        }
        last_ = std::move(box);
    }
};

// The whole set a view holds after the card's first message and then m.
void view_objects(const objects_t &m)
{
    Card card;
    ObjectsView v;
    if (v.apply(card.first_objects()) != ObjectsView::Take::applied) broken("a view refuses the card's first complete objects");
    // m, and then, if m came before its base, that base (nothing changed
    // but the block): m is then placed from where the view held it
    if (v.apply(m) == ObjectsView::Take::held) {
        objects_t base = v.whole();
        base.complete = false;
        base.base_seq = base.seq;
        base.base_fix_id = base.fix_id;
        base.seq = m.base_seq;
        base.fix_id = m.base_fix_id;
        base.particles.clear();
        base.wires.clear();
        base.n_particles = base.n_wires = 0;
        if (v.apply(base) != ObjectsView::Take::applied) broken("a view refuses a base with nothing changed");
        if (v.held() != 0) broken("a view keeps a message whose base it has placed");
    }
    if (v.held() > ObjectsView::kMaxHeld) broken("a view holds more messages than kMaxHeld");
    if (!v.ready()) broken("a view that took a complete message is not ready");
    const objects_t &w = v.whole();
    if (w.n_particles != static_cast<int32_t>(w.particles.size()) || w.n_wires != static_cast<int32_t>(w.wires.size()) ||
        w.n_trenches != static_cast<int32_t>(w.trenches.size()))
        broken("a view's whole set has counts that are not its lists' sizes");
    const std::vector<uint8_t> e = encoded(w);
    objects_t again;
    if (decode_checked(e.data(), e.size(), &again) != Reject::none) broken("a view's whole set, encoded, is refused");
}

template <class M>
Reject take(const M &) { return Reject::none; }

Reject take(const analog_block_t &b) { return Card().analog(b); }
Reject take(const haptic_pose_t &p) { return Card().pose(p); }
Reject take(const object_fix_t &f) { return Card().fix(f); }
Reject take(const fw_state_t &s)
{
    view_objects(s.objects);
    return Reject::none;
}
Reject take(const sim_truth_t &t)
{
    view_objects(t.objects);
    return Reject::none;
}

// The datagram of the message being delivered (for check_taken).
const uint8_t *g_data = nullptr;
std::size_t g_size = 0;

struct Bus {
    Inbox inbox{nullptr};
    std::vector<std::string> channels;
    Bus()
    {
#define AFM_SUBSCRIBE(CH, T)                                        \
    channels.push_back(#CH);                                        \
    inbox.on<T>(#CH, [](const T &m) {                               \
        check_taken(m, g_data, g_size);                             \
        return take(m);                                             \
    });
        AFM_CHANNEL_TYPES(AFM_SUBSCRIBE)
#undef AFM_SUBSCRIBE
    }
};

}  // namespace
}  // namespace afm

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, std::size_t size)
{
    static afm::Bus bus;
    (void)afm::scene();
    if (size < 1) return 0;
    std::string channel = bus.channels[data[0] % bus.channels.size()];
    std::size_t skip = 1;
    if (const void *nul = std::memchr(data, 0, size)) {
        const std::string name(reinterpret_cast<const char *>(data), static_cast<const uint8_t *>(nul) - data);
        if (std::find(bus.channels.begin(), bus.channels.end(), name) != bus.channels.end()) {
            channel = name;
            skip = name.size() + 1;
        }
    }
    afm::g_data = data + skip;
    afm::g_size = size - skip;
    bus.inbox.deliver(channel, data + skip, size - skip);
    return 0;
}
