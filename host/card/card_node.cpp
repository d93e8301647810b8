#include "card_node.hpp"

extern "C" {
#include "fw_units.h"
}

#include <stdexcept>

#include "afm_channels.h"
#include "lockstep.hpp"

namespace afm {

namespace {
CardBackendOptions with_scene(CardBackendOptions o, const Scene &s)
{
    o.block_hz = s.block_hz;
    o.samples_per_block = s.samples_per_block();
    return o;
}
}  // namespace

CardNode::CardNode(const Scene &s, const CardBackendOptions &where)
    : scene_(s), setup_(s), card_(make_card_backend(with_scene(where, s)))
{
    const fw_rule_t rule = card_->init(setup_.config(), setup_.storage());
    if (rule != FW_RULE_OK) throw std::runtime_error(card_refusal_text(s, setup_, rule));
    haptic_.seq = -1;   // the zero force that asks for the first pose
    state_.seq = -1;    // before the first block (a fix answered then carries the objects of block -1)
    fill_objects();
    whole_.seq = -1;
    objects_ = whole_;   // complete; not sent (the first block's message is complete: the diff has none before)
    objects_.complete = true;
}

int64_t CardNode::sim_utime_done() const { return done_ < 0 ? 0 : block_end_utime(scene_, done_); }

Outbox CardNode::on_analog(const analog_block_t &b, Reject *why)
{
    Reject ignored;
    Reject &r = why ? *why : ignored;
    r = Reject::none;
    Outbox box;
    if (b.seq == done_ && done_ >= 0) {   // a resend: our answer was lost somewhere
        post_block(box);
        return box;
    }
    if (b.seq <= done_) r = Reject::seq_past;
    else if (b.seq > done_ + 1) r = Reject::seq_future;
    else if (b.n != scene_.samples_per_block() || static_cast<std::size_t>(b.n) > b.sn_v.size()) r = Reject::out_of_range;
    if (r != Reject::none) return box;
    const bool again = pending_ != nullptr;
    if (!again) pending_ = std::make_unique<analog_block_t>(b);
    if (poses_.count(b.seq)) {
        step(box);
    } else if (again || done_ < 0) {
        // no pose for this block yet, and a resend (or the first block):
        // ask the operator for it with the force it answers, and the
        // objects of that block (an operator that steers on them waits for them)
        post(box, AFM_CH_HAPTIC_FORCE, haptic_, haptic_.seq);
        if (done_ >= 0) post_state(box);
    }
    return box;
}

Outbox CardNode::on_pose(const haptic_pose_t &p, Reject *why)
{
    Reject ignored;
    Reject &r = why ? *why : ignored;
    r = Reject::none;
    Outbox box;
    if (p.seq <= done_) r = Reject::seq_past;          // a late duplicate
    else if (p.seq > done_ + 1) r = Reject::seq_future;  // the operator answers HAPTIC_FORCE done_ with pose done_ + 1
    if (r != Reject::none) return box;
    poses_.emplace(p.seq, p);
    if (pending_ && pending_->seq == p.seq) step(box);
    return box;
}

Outbox CardNode::on_fix(const object_fix_t &f, std::string *note, Reject *why)
{
    Outbox box;
    note->clear();
    if (why) *why = f.fix_id > fix_id_ + 1 ? Reject::seq_future : Reject::none;
    if (f.fix_id > fix_id_ + 1) return box;
    if (f.fix_id == fix_id_ + 1) {
        const int32_t scan_pm[2] = {fwu_pm_from_nm(f.scan_x_nm), fwu_pm_from_nm(f.scan_y_nm)};
        fw_card_fix_out_t r{};
        card_->fix(f.kind == object_fix_t::KIND_PLACE, f.object_id, scan_pm, &r);
        if (r.result == FW_CARD_FIX_UNKNOWN_OBJECT) {
            *note = "local scan fix " + std::to_string(f.fix_id) + " names unknown object " + std::to_string(f.object_id) + "; ignored";
        } else if (r.result == FW_CARD_FIX_NOT_DRIFT) {
            const double dx = fwu_nm_from_pm(scan_pm[0] - static_cast<int64_t>(r.model_pm[0]));
            const double dy = fwu_nm_from_pm(scan_pm[1] - static_cast<int64_t>(r.model_pm[1]));
            *note = "local scan fix " + std::to_string(f.fix_id) + ": object " + std::to_string(f.object_id) + " is (" +
                    std::to_string(dx) + ", " + std::to_string(dy) + ") nm from its model, beyond the firmware's limit; not applied";
        }
        fix_id_ = f.fix_id;
        const int64_t seq = whole_.seq, utime = whole_.utime;
        fill_objects();
        whole_.seq = seq;
        whole_.utime = utime;
        objects_ = objects_diff_.next(whole_, true);
    }
    if (f.fix_id <= fix_id_) post_state(box);
    return box;
}

void CardNode::step(Outbox &box)
{
    const analog_block_t &b = *pending_;
    const haptic_pose_t &p = poses_.at(b.seq);
    block_in_.resize(static_cast<std::size_t>(b.n));
    for (int i = 0; i < b.n; ++i) {
        fw_sample_in_t &in = block_in_[static_cast<std::size_t>(i)];
        in.sn_uv = fwu_uv_from_v(b.sn_v[i]);
        in.sl_uv = fwu_uv_from_v(b.sl_v[i]);
        in.piezo_pm[0] = fwu_pm_from_nm(b.piezo_x_nm[i]);
        in.piezo_pm[1] = fwu_pm_from_nm(b.piezo_y_nm[i]);
        in.piezo_pm[2] = fwu_pm_from_nm(b.piezo_z_nm[i]);
    }
    fw_card_in_t in{};
    in.samples = block_in_.data();
    in.n = b.n;
    in.pose.joy_q15[0] = fwu_q15_from_unit(p.joy[0]);
    in.pose.joy_q15[1] = fwu_q15_from_unit(p.joy[1]);
    in.pose.load_pn = fwu_pn_from_nn(p.load_nN);
    in.pose.engaged = p.engaged;
    fw_card_out_t out{};
    card_->step_block(in, &out);

    const int64_t t_end = block_end_utime(scene_, b.seq);
    state_.utime = t_end;
    state_.seq = b.seq;
    for (int k = 0; k < 3; ++k) state_.force_nN[k] = fwu_nn_from_pn(out.force_pn[k]);
    state_.flags = static_cast<int32_t>(out.flags);
    state_.sn_code = out.code_n;
    state_.sl_code = out.code_l;
    state_.sat_count = out.sat_samples;
    tally_.saturated_samples = out.sat_samples;
    for (int k = 0; k < 3; ++k) state_.tip_nm[k] = fwu_nm_from_pm(out.tip_pm[k]);
    if (b.n > 0) {
        state_.piezo_nm[0] = b.piezo_x_nm[b.n - 1];
        state_.piezo_nm[1] = b.piezo_y_nm[b.n - 1];
        state_.piezo_nm[2] = b.piezo_z_nm[b.n - 1];
    }
    state_.cmd_nm[0] = fwu_nm_from_pm(out.target_pm[0]);
    state_.cmd_nm[1] = fwu_nm_from_pm(out.target_pm[1]);

    haptic_.utime = t_end;
    haptic_.seq = b.seq;
    for (int k = 0; k < 3; ++k) {
        haptic_.tip_force_nN[k] = state_.force_nN[k];
        haptic_.force_N[k] = fwu_n_from_un(out.haptic_un[k]);
    }
    haptic_.flags = state_.flags;

    cmd_.utime = t_end;   // it applies from the next block on
    cmd_.ack_seq = b.seq;
    cmd_.piezo_x_nm = fwu_nm_from_pm(out.piezo_cmd_pm[0]);
    cmd_.piezo_y_nm = fwu_nm_from_pm(out.piezo_cmd_pm[1]);
    cmd_.load_nN = fwu_nn_from_pn(out.load_pn);
    cmd_.engaged = out.engaged;

    fill_objects();
    if (out.flags & FW_FLAG_BLIND_PUSH) ++tally_.unobservable_push_blocks;
    whole_.utime = t_end;
    whole_.seq = b.seq;
    objects_ = objects_diff_.next(whole_);

    done_ = b.seq;
    pending_.reset();
    poses_.erase(poses_.begin(), poses_.upper_bound(done_));
    post_block(box);
}

void CardNode::post_block(Outbox &box) const
{
    // the two the next block waits for first
    post(box, AFM_CH_AFM_CMD, cmd_, cmd_.ack_seq);
    post(box, AFM_CH_HAPTIC_FORCE, haptic_, haptic_.seq);
    post_state(box);
}

void CardNode::post_state(Outbox &box) const
{
    // the block's force and apex with the objects last made (the block's, or a fix's answer)
    afm::fw_state_t m = state_;
    m.objects = objects_;
    post(box, AFM_CH_FW_STATE, m, m.seq, m.objects.fix_id);
}

void CardNode::fill_objects()
{
    const fw_models_t &m = card_->models();   // the card's models after its last call (fw_models.h)
    whole_.particles.resize(static_cast<std::size_t>(m.n_particles));
    for (int32_t i = 0; i < m.n_particles; ++i) {
        const fw_models_particle_t &p = m.particles[i];
        particle_t &q = whole_.particles[static_cast<std::size_t>(i)];
        q.id = p.id;
        q.x_nm = fwu_nm_from_pm(p.x_pm);
        q.y_nm = fwu_nm_from_pm(p.y_pm);
        q.radius_nm = fwu_nm_from_pm(p.radius_pm);
        q.in_contact = (p.flags & FW_PARTICLE_PUSHED) != 0;
    }
    whole_.n_particles = static_cast<int32_t>(whole_.particles.size());
    whole_.wires.resize(static_cast<std::size_t>(m.n_wires));
    for (int32_t i = 0; i < m.n_wires; ++i) {
        const fw_models_wire_t &w = m.wires[i];
        wire_t &q = whole_.wires[static_cast<std::size_t>(i)];
        q.id = w.id;
        q.diameter_nm = fwu_nm_from_pm(w.diameter_pm);
        q.n = 2;
        q.x_nm = {fwu_nm_from_pm(w.a_pm[0]), fwu_nm_from_pm(w.b_pm[0])};
        q.y_nm = {fwu_nm_from_pm(w.a_pm[1]), fwu_nm_from_pm(w.b_pm[1])};
        q.in_contact = (w.flags & FW_WIRE_PUSHED) != 0;
        q.axis_z_nm = fwu_nm_from_pm(w.axis_z_pm);
    }
    whole_.n_wires = static_cast<int32_t>(whole_.wires.size());
    fill_trenches(m.drift_pm);
    whole_.n_trenches = static_cast<int32_t>(whole_.trenches.size());
    whole_.drift_nm[0] = fwu_nm_from_pm(m.drift_pm[0]);
    whole_.drift_nm[1] = fwu_nm_from_pm(m.drift_pm[1]);
    whole_.fix_id = fix_id_;
}

void CardNode::fill_trenches(const int32_t drift_pm[2])
{
    // One trench per stroke: the points from one STROKE_START to the next.
    // The card's points only grow, unless a drift fix moves them all: then
    // the trenches are formed anew.
    const fw_models_t &m = card_->models();
    if (!m.litho) return;
    if (drift_pm[0] != trench_drift_pm_[0] || drift_pm[1] != trench_drift_pm_[1] || m.trench_count < trench_points_) {
        whole_.trenches.clear();
        trench_points_ = 0;
        trench_drift_pm_[0] = drift_pm[0];
        trench_drift_pm_[1] = drift_pm[1];
    }
    for (int32_t i = trench_points_; i < m.trench_count; ++i) {
        const fw_trench_point_t &p = m.trench[i];
        if ((p.flags & FW_LITHO_STROKE_START) || whole_.trenches.empty()) {
            whole_.trenches.emplace_back();
            whole_.trenches.back().id = static_cast<int32_t>(whole_.trenches.size());
        }
        trench_t &t = whole_.trenches.back();
        t.x_nm.push_back(fwu_nm_from_pm(p.x_pm));
        t.y_nm.push_back(fwu_nm_from_pm(p.y_pm));
        t.depth_nm.push_back(fwu_nm_from_pm(p.depth_pm));
        t.width_nm.push_back(fwu_nm_from_pm(p.width_pm));
        ++t.n;
    }
    trench_points_ = m.trench_count;
}

}  // namespace afm
