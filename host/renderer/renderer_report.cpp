// The renderer's account (renderer.hpp): the contact sheet, renderer_report.json, the
// assembly check (the planner's sites and rods in the fresh scan), the heartbeats it answers.
#include "lockstep.hpp"
#include "png_read.hpp"
#include "renderer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace afm::render {
void Renderer::pick_sheet()
{
    const int K = total_frames, M = std::min(scene.out.contact_sheet_frames, K);
    sheet_at.clear();
    for (int i = 0; i < M; ++i) sheet_at.push_back(M == 1 ? 0 : static_cast<int>(std::lround(i * (K - 1.0) / (M - 1))));
}

nlohmann::json Renderer::assembly_json() const
{
    using nlohmann::json;
    const afm::PlanSpec &ps = scene.op.plan;
    json out = json::object();
    const std::vector<afm::Vec2> sites = afm::target_sites(scene);
    if (!sites.empty()) {
        std::vector<cv::Point2d> at;
        for (const auto &v : sites) at.emplace_back(v.x + fw_drift_nm[0], v.y + fw_drift_nm[1]);
        double r = 0;
        for (const auto &p : scene.particles) r = std::max(r, p.radius_nm);
        const afm::SitesCheck c = afm::check_sites(scan.heights(), field, at, afm::sphere_footprint_nm(r, tip) * 0.5 + ps.tolerance_nm,
                                                       ps.tolerance_nm);
        json per = json::array();
        for (const auto &x : c.sites)
            per.push_back({{"site_nm", {x.x_nm, x.y_nm}}, {"found", x.found}, {"scan_nm", {x.scan_x_nm, x.scan_y_nm}},
                           {"error_nm", x.found ? json(x.error_nm) : json(nullptr)}});
        out["particles"] = {{"sites", sites.size()}, {"placed", c.placed}, {"missing", c.missing}, {"tolerance_nm", ps.tolerance_nm},
                            {"worst_nm", c.worst_nm}, {"rms_nm", c.rms_nm}, {"per_site", per}};
    }
    json rods = json::array();
    for (const auto &t : scene.wire_targets) {
        double length = 0, d = 0;
        for (const auto &w : scene.wires)
            if (w.id == t.id) length = std::hypot(w.x1_nm - w.x0_nm, w.y1_nm - w.y0_nm), d = w.diameter_nm;
        const afm::RodCheck c = afm::check_rod(scan.heights(), field, {t.x_nm + fw_drift_nm[0], t.y_nm + fw_drift_nm[1]}, t.angle_deg,
                                               length, afm::wire_footprint_nm(d / 2, tip) + ps.wire_tolerance_nm);
        rods.push_back({{"id", t.id}, {"found", c.found}, {"error_nm", c.found ? json(c.error_nm) : json(nullptr)},
                        {"centroid_error_nm", c.centroid_error_nm}, {"angle_error_deg", c.angle_error_deg},
                        {"placed", c.found && c.error_nm <= ps.wire_tolerance_nm}, {"tolerance_nm", ps.wire_tolerance_nm}});
    }
    if (!rods.empty()) out["rods"] = rods;
    return out;
}

afm::Reject Renderer::on_heartbeat(const afm::heartbeat_t &m)
{
    if (afm::run_over(m)) sim_done = true;
    if (afm::says(m, "sim_afm", afm::RunState::ending)) {
        // The run ends at block m.seq (the planner finished): its last
        // frame is the last one due by then. The sheet is picked again
        // over the shorter run (frames already written that it now
        // wants are read back from frames/ at the end).
        const int end = std::max(frames_written + 1, afm::frames_due(scene, afm::block_end_utime(scene, m.seq)));
        if (end < total_frames) {
            total_frames = end;
            pick_sheet();
        }
    }
    return afm::Reject::none;
}

// Writes contact_sheet.png: the frames picked over the run, those not kept in memory
// (picked again after an early end) read back from frames/.
void write_contact_sheet(Renderer &r, const afm::Scene &scene, const std::string &out_dir)
{
    std::vector<cv::Mat> tiles;
    for (int k : r.sheet_at) {
        if (k >= r.frames_written) continue;
        if (r.sheet.count(k)) {
            tiles.push_back(r.sheet[k]);
        } else if (scene.out.png) {
            char name[64];
            std::snprintf(name, sizeof name, "/frames/frame_%05d.png", k);
            const cv::Mat f = afm::read_png(out_dir + name, true);
            if (!f.empty()) tiles.push_back(f);
        }
    }
    if (!tiles.empty()) {
        const int cols = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(tiles.size()))));
        afm::write_png(out_dir + "/contact_sheet.png", afm::contact_sheet(tiles, cols));
    }
}

// renderer_report.json: the frames, what they cost, what the renderer refused.
nlohmann::json report_json(const Renderer &r, const afm::Scene &scene, const nlohmann::json &rejected)
{
    return {{"frames", r.frames_written},
            {"objects_blocks_missed", r.objects_missed()},
            {"frames_mixed_blocks", r.frames_mixed_blocks},
            {"frames_expected", r.total_frames},
            {"image_px", scene.out.image_px},
            {"frame_px", afm::frame_px(scene.out.image_px)},   // the frames' side (frame_overlay.hpp)
            {"update_mode", scene.out.update_mode},
            {"update_ms_per_frame", r.frames_written ? 1e3 * r.update_s / r.frames_written : 0.0},
            {"compose_ms_per_frame", r.frames_written ? 1e3 * r.compose_s / r.frames_written : 0.0},
            // the writer thread's CPU time (frame_writer.hpp), not its wall time
            {"write_ms_per_frame", r.writer && r.writer->written() ? 1e3 * r.writer->cpu_seconds() / r.writer->written() : 0.0},
            {"writer_waits", r.writer ? r.writer->waits() : 0},
            {"writer_wait_s", r.writer ? r.writer->wait_seconds() : 0.0},
            // which video ran: H.264 through ffmpeg, or OpenCV's fallback and why (frame_writer.hpp)
            {"video", r.writer ? r.writer->video() : nlohmann::json(nullptr)},
            // a capital's height in the frames' labels and in fidelity_diff.png, pixels
            // (the report shows them so that it reads 9 px or more: analysis/run_report.py)
            {"label_cap_px", afm::frame_text(afm::frame_px(scene.out.image_px)).cap_px},
            {"fidelity_label_cap_px", afm::figure_text().cap_px},
            {"pixels_updated", r.touched_px},
            {"local_scans", r.local_scans},
            {"page_scans_pasted", r.page_pasted},   // a person's local scans (operator.mode browser)
            {"view", r.view ? r.view->report() : nlohmann::json(nullptr)},
            {"rejected", rejected}};
}

}  // namespace afm::render
