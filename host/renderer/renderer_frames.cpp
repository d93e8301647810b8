// The renderer's frames (renderer.hpp): the card's states taken by block,
// the model set, frames drawn, written, offered and announced, the last
// frame's fidelity check.
#include "lockstep.hpp"
#include "renderer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace afm::render {
afm::Reject Renderer::block_message(int64_t seq, int64_t utime) const
{
    if (seq < -1) return afm::Reject::out_of_range;
    if (seq > last_seq + blocks_ahead) return afm::Reject::seq_future;
    if (seq >= 0 && utime != afm::block_end_utime(scene, seq)) return afm::Reject::out_of_range;
    return afm::Reject::none;
}

void Renderer::write_display_gsf(const std::string &name, const cv::Mat &h, int k)
{
    std::string err;
    if (!afm::write_gsf(out + "/" + name + ".gsf", h, field, cv::Rect(0, 0, h.cols, h.rows), name, &err,
                        gsf_meta("Height", afm::frame_utime(scene, k), "Frame", k)))
        throw std::runtime_error(err);
}

void Renderer::open_writer()
{
    writer = std::make_unique<afm::FrameWriter>(out, scene.out.png, scene.out.video, scene.frame_rate_hz, afm::frame_px(field.px), writer_cpus);
}

void Renderer::begin()
{
    display.start(scan.heights(), model);
    afm::write_png(out + "/scan_initial.png", afm::scan_figure(display, scan.heights(), "initial scan: height (nm)"));
    write_scan_gsf("scan_initial", cv::Rect(0, 0, field.px, field.px));
    if (!writer) open_writer();
    writer->wait_open();   // the encoder up before the first block (frame_writer.hpp)
    started = true;
}

void Renderer::write_frame(int k)
{
    auto t0 = std::chrono::steady_clock::now();
    afm::Overlay o;
    o.t_s = afm::frame_utime(scene, k) * 1e-6;
    const afm::fw_state_t state = states.at(shown_seq);
    o.tip_nm[0] = state.tip_nm[0];
    o.tip_nm[1] = state.tip_nm[1];
    for (int i = 0; i < 3; ++i) o.force_nN[i] = state.force_nN[i];
    o.flags = state.flags;
    if (state.seq != shown_seq) ++frames_mixed_blocks;
    if (!scene.op.plan.enabled) {   // a hand on the device (the planner drives the pose itself)
        const afm::haptic_force_t hand = hands.at(shown_seq);
        o.hand_N[0] = hand.force_N[0];
        o.hand_N[1] = hand.force_N[1];
        o.hand_scale_N = std::min(kHandGaugeThresholds * scene.op.feel_threshold_N, scene.op.haptic.max_force_N);
    }
    // the overlay on a copy: display.height() stays the physical image (frame_overlay.hpp)
    const cv::Mat frame = afm::compose_frame(display, model, o, lever);
    if (view) view->offer(frame, view_state(k, state, o));
    composed.emplace_back(k, frame);
    if (std::find(sheet_at.begin(), sheet_at.end(), k) != sheet_at.end()) sheet[k] = frame;
    compose_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

afm::view_frame_t Renderer::view_state(int k, const afm::fw_state_t &state, const afm::Overlay &o) const
{
    afm::view_frame_t m{};
    m.utime = afm::frame_utime(scene, k);
    m.index = k;
    m.frames_total = total_frames;
    m.seq = shown_seq;
    m.width = m.height = afm::frame_px(field.px);
    m.field_nm[0] = field.x0_nm;
    m.field_nm[1] = field.y0_nm;
    m.field_nm[2] = field.size_nm;
    for (int i = 0; i < 2; ++i) m.tip_nm[i] = o.tip_nm[i];
    for (int i = 0; i < 3; ++i) m.force_nN[i] = o.force_nN[i];
    m.hand_N[0] = o.hand_N[0];
    m.hand_N[1] = o.hand_N[1];
    m.flags = state.flags;
    for (const auto &p : model.particles) {
        afm::particle_t q{};
        q.id = p.id;
        q.x_nm = p.x_nm;
        q.y_nm = p.y_nm;
        q.radius_nm = p.radius_nm;
        m.particles.push_back(q);
    }
    m.n_particles = static_cast<int32_t>(m.particles.size());
    return m;
}

void Renderer::write_composed(int upto)
{
    while (!composed.empty() && composed.front().first <= upto) {   // the last frame waits for its check (continue_frames)
        writer->write(composed.front().first, std::move(composed.front().second));
        composed.erase(composed.begin());
    }
}

void Renderer::announce(int k, int64_t seq)
{
    afm::render_frame_t m;
    m.utime = afm::frame_utime(scene, k);
    m.index = k;
    m.seq = seq;
    afm::publish(lc, AFM_CH_RENDER_FRAME, m);
    write_composed(k);
}

afm::Reject Renderer::on_state(const afm::fw_state_t &m)
{
    if (const afm::Reject r = block_message(m.seq, m.utime); r != afm::Reject::none) return r;
    if (m.objects.seq != m.seq || m.objects.utime != m.utime) return afm::Reject::out_of_range;
    dewarp.follow(m.seq, m.utime, m.piezo_nm[0], m.piezo_nm[1]);
    // A block older than the newest (the bus reordered them) is not kept
    // for the frames (BySeq), but its objects are taken: the next
    // block's lists only what changed since it (objects_t.lcm).
    states.put(m);
    return take_objects(m.objects);
}

afm::Reject Renderer::on_haptic(const afm::haptic_force_t &m)
{
    if (const afm::Reject r = block_message(m.seq, m.utime); r != afm::Reject::none) return r;
    const afm::Reject r = hands.put(m);
    if (view && r == afm::Reject::none) view->sample(m);
    return r;
}

void Renderer::set_model(const afm::objects_t &m)
{
    fw_drift_nm[0] = m.drift_nm[0];
    fw_drift_nm[1] = m.drift_nm[1];
    model.particles.clear();
    for (const auto &p : m.particles) model.particles.push_back({p.id, p.x_nm, p.y_nm, p.radius_nm});
    // Wires: the firmware's once it models them; until then the scene's,
    // where they were laid.
    if (m.n_wires > 0) {
        model.wires.clear();
        for (const auto &w : m.wires) model.wires.push_back(display_wire(w));
    }
    model.trenches.clear();
    for (const auto &t : m.trenches) model.trenches.push_back(display_trench(t));
    const auto t0 = std::chrono::steady_clock::now();
    touched_px += scene.out.update_mode == "full" ? display.redraw(model) : display.update(model);
    update_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

afm::Reject Renderer::take_objects(const afm::objects_t &msg)
{
    count_objects_block(msg.seq);
    // Every message keeps the whole set; what follows reads the set. One
    // that came before the block it follows is held, and the set moves on
    // when that block comes (ObjectsView).
    switch (objects.apply(msg)) {
    case afm::ObjectsView::Take::refused: return afm::Reject::out_of_range;
    case afm::ObjectsView::Take::held: return afm::Reject::none;
    case afm::ObjectsView::Take::applied: break;
    }
    objects_frames(&objects.whole());
    return afm::Reject::none;
}

void Renderer::count_objects_block(int64_t seq)
{
    if (seq > objects_seq) {
        for (int64_t k = objects_seq + 1; objects_seq >= 0 && k < seq; ++k) {
            if (objects_gaps.size() < kMaxGaps) objects_gaps.insert(k);
            else ++objects_gaps_uncounted;
        }
        objects_seq = seq;
    } else {
        objects_gaps.erase(seq);
    }
}

void Renderer::objects_frames(const afm::objects_t *m)
{
    if (!started || final_pending) return;
    if (local_pending >= 0) {
        // Waiting for the firmware to apply the local scan's fix.
        if (fix_awaited > 0 && m->fix_id >= fix_awaited) {
            // The model is re-registered: move the objects, then let the
            // local scan replace its region (the substrate under the
            // objects' corrected footprints is what the scan shows).
            const double ddx = m->drift_nm[0] - fw_drift_nm[0], ddy = m->drift_nm[1] - fw_drift_nm[1];
            set_model(*m);
            // A landmark fix re-registers the whole work space: the
            // background (the last scan) moves with the sample too.
            if (fix_on_landmark) display.shift_background(ddx, ddy);
            display.paste_scan(scan.heights(), scan_px);
            local_scans.back()["model_drift_nm"] = {m->drift_nm[0], m->drift_nm[1]};
            local_pending = -1;
            fix_awaited = 0;
            // The frames paused and those queued meanwhile show the fixed
            // model, with the force and tip of the fix's block.
            for (const Due &d : due_queue) due_pending = std::max(due_pending, d.due);
            due_queue.clear();
            due_queue.push_back({m->seq, due_pending, std::nullopt});
            draw_ready();
        }
        return;
    }
    if (m->seq <= last_seq) {       // a resend: our announcement may be lost
        if (frames_written > 0) announce(frames_written - 1, shown_seq);
        return;
    }
    last_seq = m->seq;
    const int due = afm::frames_due(scene, m->utime);
    if (due <= due_queued) return;
    due_queued = due;
    due_queue.push_back({m->seq, due, *m});
    draw_ready();
}

void Renderer::draw_ready()
{
    while (!due_queue.empty() && started && local_pending < 0 && !final_pending) {
        Due &d = due_queue.front();
        shown_seq = std::max(shown_seq, d.seq);
        due_pending = std::max(due_pending, d.due);
        if (d.objects) set_model(*d.objects);
        due_queue.pop_front();
        continue_frames();
    }
}

void Renderer::continue_frames()
{
    const int total = total_frames;
    while (frames_written < due_pending) {
        if (local_next < static_cast<int>(scene.op.local_scans.size()) && frames_written >= afm::local_scan_frame(scene, local_next)) {
            start_local_scan(local_next++);
            return;
        }
        if (frames_written == total - 1) {
            final_pending = true;
            write_frame(frames_written);   // announced (and counted) once the check is done: finish_last_frame
            start_scan(kFinalScan, cv::Rect(0, 0, field.px, field.px));
            return;
        }
        write_frame(frames_written++);
    }
    announce(frames_written - 1, shown_seq);
    hb.maybe_send(afm::RunState::running, last_seq, afm::frame_utime(scene, frames_written - 1), kProgressPeriodUs);
}

void Renderer::finish_last_frame()
{
    final_pending = false;
    const int last = frames_written++;   // composed before the scan (continue_frames)
    announce(last, shown_seq);
    const afm::Fidelity f = afm::compare_with_scan(display.height(), scan.heights(), field, model, tip, kFidelitySearch_nm);
    write_scan_gsf("scan_final", cv::Rect(0, 0, field.px, field.px));
    write_display_gsf("display_final", display.height(), last);
    afm::write_png(out + "/fidelity_diff.png", afm::fidelity_figure(f, field, model, kFidelityTarget_nm));
    using nlohmann::json;
    fidelity = json{{"max_position_error_nm", f.max_position_error_nm},
                    {"max_angle_error_deg", f.max_angle_error_deg},
                    {"rms_height_error_nm", f.rms_height_error_nm},
                    {"trenches", model.trenches.size()},
                    {"target_nm", kFidelityTarget_nm},
                    {"pass", f.max_position_error_nm <= kFidelityTarget_nm},
                    {"frame", last},
                    {"dewarp", dewarp_json(scan.dewarp_note())},
                    {"objects", json::array()}};
    for (const auto &o : f.objects) {
        json rec = {{"kind", o.kind}, {"id", o.id}, {"found", o.found}, {"error_nm", o.found ? json(o.error_nm) : json(nullptr)},
                    {"display_nm", {o.display_x_nm, o.display_y_nm}}, {"scan_nm", {o.scan_x_nm, o.scan_y_nm}}};
        if (o.kind == "wire" && o.found) {
            rec["centroid_error_nm"] = o.centroid_error_nm;
            rec["display_angle_deg"] = o.display_angle_deg;
            rec["scan_angle_deg"] = o.scan_angle_deg;
            rec["angle_error_deg"] = o.angle_error_deg;
        }
        fidelity["objects"].push_back(rec);
    }
    if (scene.op.plan.enabled || scene.op.mode == "env") fidelity["assembly"] = assembly_json();
    afm::write_report(out + "/fidelity.json", fidelity);
}

}  // namespace afm::render
