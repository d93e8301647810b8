// afm_replay's comparison of one output (replay_fields.hpp).
#include "replay_fields.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "afm_channels.h"

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

// An objects_t's fields into x, each name after pre.
void flatten_objects(const afm::objects_t &m, const std::string &pre, Flat &x)
{
    const char *xyz[3] = {"[0]", "[1]", "[2]"};
    x.add(pre + "utime", m.utime);
    x.add(pre + "seq", m.seq);
    x.add(pre + "complete", m.complete);
    x.add(pre + "n_particles", m.n_particles);
    for (std::size_t i = 0; i < m.particles.size(); ++i) {
        const auto &p = m.particles[i];
        const std::string n = pre + "particles[" + std::to_string(i) + "].";
        x.add(n + "id", p.id);
        x.pos_nm(n + "x_nm", p.x_nm);
        x.pos_nm(n + "y_nm", p.y_nm);
        x.pos_nm(n + "radius_nm", p.radius_nm);
        x.add(n + "in_contact", p.in_contact);
    }
    x.add(pre + "n_wires", m.n_wires);
    for (std::size_t i = 0; i < m.wires.size(); ++i) {
        const auto &w = m.wires[i];
        const std::string n = pre + "wires[" + std::to_string(i) + "].";
        x.add(n + "id", w.id);
        x.pos_nm(n + "diameter_nm", w.diameter_nm);
        x.add(n + "n", w.n);
        for (std::size_t j = 0; j < w.x_nm.size(); ++j) {
            x.pos_nm(n + "x_nm[" + std::to_string(j) + "]", w.x_nm[j]);
            x.pos_nm(n + "y_nm[" + std::to_string(j) + "]", w.y_nm[j]);
        }
        x.add(n + "in_contact", w.in_contact);
    }
    x.add(pre + "n_trenches", m.n_trenches);
    for (std::size_t i = 0; i < m.trenches.size(); ++i) {
        const auto &t = m.trenches[i];
        const std::string n = pre + "trenches[" + std::to_string(i) + "].";
        x.add(n + "id", t.id);
        x.add(n + "n", t.n);
        for (std::size_t j = 0; j < t.x_nm.size(); ++j) {
            const std::string nj = "[" + std::to_string(j) + "]";
            x.pos_nm(n + "x_nm" + nj, t.x_nm[j]);
            x.pos_nm(n + "y_nm" + nj, t.y_nm[j]);
            x.pos_nm(n + "depth_nm" + nj, t.depth_nm[j]);
            x.pos_nm(n + "width_nm" + nj, t.width_nm[j]);
        }
    }
    for (int k = 0; k < 2; ++k) x.pos_nm(pre + "drift_nm" + xyz[k], m.drift_nm[k]);
    x.add(pre + "fix_id", m.fix_id);
}

Flat flatten(const std::string &ch, const std::vector<uint8_t> &d)
{
    Flat x;
    const char *xyz[3] = {"[0]", "[1]", "[2]"};
    if (ch == AFM_CH_AFM_CMD) {
        const auto m = decode_recorded<afm::tip_cmd_t>(d, "tip_cmd_t");
        x.add("utime", m.utime);
        x.add("ack_seq", m.ack_seq);
        x.pos_nm("piezo_x_nm", m.piezo_x_nm);
        x.pos_nm("piezo_y_nm", m.piezo_y_nm);
        x.force_nN("load_nN", m.load_nN);
        x.add("engaged", m.engaged);
    } else if (ch == AFM_CH_HAPTIC_FORCE) {
        const auto m = decode_recorded<afm::haptic_force_t>(d, "haptic_force_t");
        x.add("utime", m.utime);
        x.add("seq", m.seq);
        for (int k = 0; k < 3; ++k) x.add(std::string("force_N") + xyz[k], m.force_N[k]);
        for (int k = 0; k < 3; ++k) x.force_nN(std::string("tip_force_nN") + xyz[k], m.tip_force_nN[k]);
        x.add("flags", m.flags);
    } else if (ch == AFM_CH_FW_STATE) {
        const auto m = decode_recorded<afm::fw_state_t>(d, "fw_state_t");
        x.add("utime", m.utime);
        x.add("seq", m.seq);
        for (int k = 0; k < 3; ++k) x.force_nN(std::string("force_nN") + xyz[k], m.force_nN[k]);
        x.add("flags", m.flags);
        x.add("sn_code", m.sn_code);
        x.add("sl_code", m.sl_code);
        x.add("sat_count", static_cast<double>(m.sat_count));
        for (int k = 0; k < 3; ++k) x.pos_nm(std::string("tip_nm") + xyz[k], m.tip_nm[k]);
        for (int k = 0; k < 3; ++k) x.pos_nm(std::string("piezo_nm") + xyz[k], m.piezo_nm[k]);
        for (int k = 0; k < 2; ++k) x.pos_nm(std::string("cmd_nm") + xyz[k], m.cmd_nm[k]);
        flatten_objects(m.objects, "objects.", x);
    }
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
