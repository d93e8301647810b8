// The renderer's scans (renderer.hpp): the full scans, a person's local
// scans pasted into the display, the scene's local scans and the fixes they
// send.
#include "lockstep.hpp"
#include "renderer.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace afm::render {
void Renderer::start_scan(int req, const cv::Rect &region)
{
    // Region in display pixels -> frame A: row 0 is the top of the field.
    scan_px = region;
    afm::ScanRegion r;
    r.x0_nm = field.x0_nm + region.x * field.pitch();
    r.y0_nm = field.y0_nm + (field.px - region.y - region.height) * field.pitch();
    r.width_nm = region.width * field.pitch();
    r.height_nm = region.height * field.pitch();
    r.nx = region.width;
    r.ny = region.height;
    scan_lateral = cv::Mat(region.height, region.width, CV_32F, cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
    scan_utime = 0;
    scan.start(req, r);
}

void Renderer::keep_line(const afm::scan_line_t &m)
{
    if (!scan.busy() || m.req_id != scan.id() || m.n != scan_lateral.cols || m.line < 0 || m.line >= scan_lateral.rows ||
        static_cast<int>(m.lat_v.size()) != m.n)
        return;
    float *row = scan_lateral.ptr<float>(scan_lateral.rows - 1 - m.line);
    for (int i = 0; i < m.n; ++i) row[i] = static_cast<float>(m.lat_v[static_cast<std::size_t>(i)]);
    scan_utime = std::max(scan_utime, m.utime);
}

afm::GsfMeta Renderer::gsf_meta(const std::string &channel, int64_t utime, const std::string &source, int source_id) const
{
    char date[32];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    auto num = [](double v) { char b[32]; std::snprintf(b, sizeof b, "%.9g", v); return std::string(b); };
    afm::GsfMeta m;
    m.keys = {{"Scene", scene.name},
              {"Load_nN", num(scene.op.load_nN)},
              {"SetPoint_nN", num(scene.op.scan_load_nN.value_or(scene.op.load_nN))},
              {"ScanAngle_deg", num(scene.probe.scan_angle_deg)},
              {"SimTime_s", num(utime * 1e-6)},
              {"Date", date},
              {"Channel", channel},
              {source, std::to_string(source_id)}};
    if (channel == "Lateral") {
        m.scale = 1.0;
        m.z_units = "V";
    }
    return m;
}

void Renderer::write_scan_gsf(const std::string &name, const cv::Rect &region)
{
    std::string err;
    if (!afm::write_gsf(out + "/" + name + ".gsf", scan.heights(), field, region, name, &err,
                        gsf_meta("Height", scan_utime, "ScanRequest", scan.id())))
        throw std::runtime_error(err);
    if (cv::checkRange(scan_lateral, true, nullptr, -1e30, 1e30) &&
        !afm::write_gsf(out + "/" + name + "_lateral.gsf", scan_lateral, field, region, name + " lateral", &err,
                        gsf_meta("Lateral", scan_utime, "ScanRequest", scan.id())))
        throw std::runtime_error(err);
}

nlohmann::json dewarp_json(const afm::DewarpNote &n)
{
    return {{"dewarped", n.dewarped}, {"shift_nm", n.shift_nm}, {"aim_nm", n.aim_nm}, {"model_s", n.model_utime * 1e-6},
            {"scan_s", n.scan_utime * 1e-6}};
}

afm::Reject Renderer::page_line(const afm::scan_line_t &m)
{
    const double pitch = field.pitch();
    if (!started || m.n < 1 || m.n_lines < 1 || m.n > field.px || m.n_lines > field.px || m.line < 0 || m.line >= m.n_lines ||
        static_cast<int>(m.height_nm.size()) != m.n || std::fabs(m.dx_nm - pitch) > 1e-6 * pitch)
        return afm::Reject::out_of_range;
    const int col = static_cast<int>(std::lround((m.x0_nm - field.x0_nm) / pitch - 0.5));
    const int top = static_cast<int>(std::lround(field.px - 1 - ((m.y_nm - field.y0_nm) / pitch - 0.5))) - (m.n_lines - 1 - m.line);
    const cv::Rect where(col, top, m.n, m.n_lines);
    if ((where & cv::Rect(0, 0, field.px, field.px)) != where) return afm::Reject::out_of_range;
    auto it = page_open.find(m.req_id);
    if (it == page_open.end()) {
        if (page_open.size() >= kPageScansOpen) page_open.erase(page_open.begin());
        PageScan p{where, cv::Mat(m.n_lines, m.n, CV_32F, cv::Scalar(0)), std::vector<bool>(static_cast<std::size_t>(m.n_lines)), m.n_lines};
        it = page_open.emplace(m.req_id, std::move(p)).first;
    }
    PageScan &p = it->second;
    if (p.where != where) return afm::Reject::out_of_range;
    if (p.got[static_cast<std::size_t>(m.line)]) return afm::Reject::none;   // sent again
    p.got[static_cast<std::size_t>(m.line)] = true;
    float *row = p.heights.ptr<float>(m.n_lines - 1 - m.line);
    for (int i = 0; i < m.n; ++i) row[i] = static_cast<float>(m.height_nm[static_cast<std::size_t>(i)]);
    if (--p.left == 0) {
        afm::ScanRegion r;   // the request's rectangle, as the operator asked it on the display's pixels
        r.x0_nm = m.x0_nm - 0.5 * pitch;
        r.y0_nm = m.y_nm - (m.line + 0.5) * pitch;
        r.width_nm = m.n * pitch;
        r.height_nm = m.n_lines * pitch;
        r.nx = m.n;
        r.ny = m.n_lines;
        display.paste_scan(dewarp.apply(p.heights, r), p.where);
        ++page_pasted;
        page_open.erase(it);
    }
    return afm::Reject::none;
}

afm::Reject Renderer::on_line(const afm::scan_line_t &m)
{
    if (m.req_id >= afm::kPageScanReqBase) return page_line(m);
    keep_line(m);
    if (!scan.on_line(m)) return afm::Reject::none;   // a line of another client's scan, or one already here
    scan_lateral = scan.placed(scan_lateral);   // as the heights are (the scan client)
    if (scan.id() == kFinalScan && final_pending) finish_last_frame();
    else if (local_pending >= 0 && scan.id() == kLocalScanBase + local_pending) local_scan_done();
    return afm::Reject::none;
}

bool Renderer::landmark_or_particle_at(int id, double *x, double *y) const
{
    for (const auto &p : model.particles)
        if (p.id == id) {
            *x = p.x_nm;
            *y = p.y_nm;
            return false;
        }
    for (const auto &m : scene.landmarks)
        if (m.id == id) {
            *x = m.x_nm + fw_drift_nm[0];
            *y = m.y_nm + fw_drift_nm[1];
            return true;
        }
    return false;
}

void Renderer::start_local_scan(int i, double size_nm)
{
    const afm::LocalScanSpec &ls = scene.op.local_scans[i];
    local_pending = i;
    local_size_nm = size_nm > 0 ? size_nm : ls.size_nm;
    local_wide = size_nm > 0;
    double x = 0, y = 0;
    landmark_or_particle_at(ls.around_id, &x, &y);
    const int half = std::max(2, static_cast<int>(std::lround(local_size_nm / 2 / field.pitch())));
    const cv::Point2d c = field.to_px(x, y);
    const cv::Rect region = cv::Rect(cvRound(c.x) - half, cvRound(c.y) - half, 2 * half, 2 * half) & cv::Rect(0, 0, field.px, field.px);
    start_scan(kLocalScanBase + i, region);
}

double Renderer::drift_limit_nm() const
{
    return scene.fw_cal.drift_max_step_nm.value_or(FW_DRIFT_MAX_STEP_DEFAULT_PM * 1e-3);
}

void Renderer::local_scan_done()
{
    const afm::LocalScanSpec &ls = scene.op.local_scans[local_pending];
    {
        write_scan_gsf("scan_local_" + std::to_string(local_pending + 1) + (local_wide ? "_wide" : ""), scan_px);
    }
    // Locate the object in the scan (placed in a full-size image so the
    // display's geometry applies).
    cv::Mat located = cv::Mat::zeros(field.px, field.px, CV_32F);
    scan.heights().copyTo(located(scan_px));
    double mx = 0, my = 0, search = 0, radius = 0;
    fix_on_landmark = landmark_or_particle_at(ls.around_id, &mx, &my);
    bool known = fix_on_landmark;
    std::vector<cv::Point2d> others;
    for (const auto &p : model.particles) {
        if (p.id == ls.around_id) {
            search = afm::sphere_footprint_nm(p.radius_nm, tip) * 0.5 + kFidelitySearch_nm;
            radius = p.radius_nm;
            known = true;
        } else {
            others.emplace_back(p.x_nm, p.y_nm);
        }
    }
    // A landmark may have jumped far (a cantilever change): look over the
    // whole local scan for it.
    if (fix_on_landmark) search = ls.size_nm / 2;
    double sx = 0, sy = 0;
    nlohmann::json rec = {{"at_s", ls.at_s}, {"around_id", ls.around_id}, {"frame", frames_written},
                          {"kind", fix_on_landmark ? "landmark" : "particle"}, {"size_nm", local_size_nm},
                          {"wide", local_wide}, {"dewarp", dewarp_json(scan.dewarp_note())}};
    // A particle drifted out of reach of its model: in the wider retry,
    // the bump nearest its model (physics.md 10: the scan is wide enough
    // for any drift the card accepts).
    const bool found = known && (local_wide ? afm::nearest_bump(located, field, mx, my, 0.5 * radius, search, others,
                                                                radius, &sx, &sy)
                                            : afm::locate_bump(located, field, mx, my, search, &sx, &sy));
    if (!found) {
        rec["found"] = false;
        local_scans.push_back(rec);
        display.paste_scan(scan.heights(), scan_px);
        // Not where its model is: scan again, wide enough to hold any
        // object within the card's correction limit of its model.
        const double wide = 2.0 * (drift_limit_nm() + search);
        if (!fix_on_landmark && known && !local_wide && wide > local_size_nm) {
            start_local_scan(local_pending, wide);
            return;
        }
        // Nothing to register: the scan still replaces its region of the image.
        local_pending = -1;
        continue_frames();
        draw_ready();
        return;
    }
    const bool place = !fix_on_landmark && ls.place;
    rec["found"] = true;
    rec["model_nm"] = {mx, my};
    rec["scan_nm"] = {sx, sy};
    rec["fix"] = place ? "place" : "drift";
    local_scans.push_back(rec);
    fix_msg.utime = afm::frame_utime(scene, frames_written);
    fix_msg.fix_id = ++fixes_sent;
    fix_msg.object_id = ls.around_id;
    fix_msg.scan_x_nm = sx;
    fix_msg.scan_y_nm = sy;
    fix_msg.kind = place ? afm::object_fix_t::KIND_PLACE : afm::object_fix_t::KIND_DRIFT;
    fix_awaited = fix_msg.fix_id;
    send_fix();
}

void Renderer::send_fix()
{
    afm::publish(lc, AFM_CH_HOST_OBJECT_FIX, fix_msg);
    fix_sent = std::chrono::steady_clock::now();
}

void Renderer::retry_fix()
{
    if (fix_awaited > 0 && std::chrono::steady_clock::now() - fix_sent > std::chrono::milliseconds(kFixRetryMs)) send_fix();
}

}  // namespace afm::render
