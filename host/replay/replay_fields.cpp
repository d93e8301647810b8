// afm_replay's comparison of one output (replay_fields.hpp).
#include "replay_fields.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "afm_channels.h"
#include "afm_lcm_walk.hpp"

namespace afm::replay {

const std::vector<std::string> kOutputs = {AFM_CH_AFM_CMD, AFM_CH_HAPTIC_FORCE, AFM_CH_FW_STATE};

const std::vector<std::string> kBeforeFwState = {"FW_FORCE", "FW_TIP", "FW_OBJECTS"};

int output_rank(const std::string &ch)
{
    for (std::size_t i = 0; i < kOutputs.size(); ++i)
        if (kOutputs[i] == ch) return static_cast<int>(i);
    return -1;
}

Key output_key(const std::string &ch, const std::vector<uint8_t> &d)
{
    const int r = output_rank(ch);
    if (ch == AFM_CH_AFM_CMD) return {decode_recorded<afm::tip_cmd_t>(d, "tip_cmd_t").ack_seq, r, 0};
    if (ch == AFM_CH_HAPTIC_FORCE) return {decode_recorded<afm::haptic_force_t>(d, "haptic_force_t").seq, r, 0};
    const auto m = decode_recorded<afm::fw_state_t>(d, "fw_state_t");   // FW_STATE: a block's, or a fix's answer
    return {m.seq, r, m.objects.fix_id};
}

Flat flatten(const std::string &ch, const std::vector<uint8_t> &d)
{
    Flat x;
    if (ch == AFM_CH_AFM_CMD)
        lcm_walk::walk(decode_recorded<afm::tip_cmd_t>(d, "tip_cmd_t"), "", x);
    else if (ch == AFM_CH_HAPTIC_FORCE)
        lcm_walk::walk(decode_recorded<afm::haptic_force_t>(d, "haptic_force_t"), "", x);
    else if (ch == AFM_CH_FW_STATE)
        lcm_walk::walk(decode_recorded<afm::fw_state_t>(d, "fw_state_t"), "", x);
    return x;
}

std::string fmt(double v)
{
    std::ostringstream o;
    o.precision(10);
    o << v;
    return o.str();
}

// Compares one recorded output with the replay's; fills the per-channel
// figures, and the divergence's text if it is the first.
bool compare(const std::string &ch, const std::vector<uint8_t> &rec, const std::vector<uint8_t> &now, ChannelStats *st,
             std::string *first)
{
    ++st->compared;
    if (rec == now) return true;
    ++st->differing;
    const Flat a = flatten(ch, rec), b = flatten(ch, now);
    bool named = false;
    for (std::size_t i = 0; i < std::min(a.f.size(), b.f.size()); ++i) {
        const Field &x = a.f[i], &y = b.f[i];
        if (x.name != y.name) {   // a count differs: the layouts part here
            if (!named) *first = "field " + x.name + " (recorded) against " + y.name + " (replayed): the number of objects differs";
            return false;
        }
        if (x.value == y.value) continue;
        const double d = std::fabs(x.value - y.value);
        if (x.unit == Unit::kForce_pN) st->worst_pN = std::max(st->worst_pN, d);
        if (x.unit == Unit::kPosition_nm) st->worst_nm = std::max(st->worst_nm, d);
        if (!named) {
            const char *u = x.unit == Unit::kForce_pN ? " pN" : x.unit == Unit::kPosition_nm ? " nm" : "";
            *first = "field " + x.name + ": recorded " + fmt(x.value) + u + ", replayed " + fmt(y.value) + u;
            named = true;
        }
    }
    if (!named) *first = "the messages differ in length (" + std::to_string(rec.size()) + " against " + std::to_string(now.size()) + " bytes)";
    return false;
}

}  // namespace afm::replay
