// renderer: the videolized display, off-screen. Starts from a full scan, then
// updates the image locally from the firmware's object states (erase each
// moved object's old footprint, draw the new one with the profile a scan
// would show), draws the tip and the measured force, and writes a PNG per
// frame and a video at the scene's frame rate. Lockstep: it announces each
// frame on RENDER_FRAME and the simulator waits for it.
#include <lcm/lcm-cpp.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "afm/fw_force_t.hpp"
#include "afm/fw_tip_t.hpp"
#include "afm/heartbeat_t.hpp"
#include "afm/objects_t.hpp"
#include "afm/render_frame_t.hpp"
#include "afm/scan_line_t.hpp"
#include "afm/scan_req_t.hpp"
#include "bus.hpp"
#include "profile.hpp"
#include "scene.hpp"

namespace {

const char *kUsage =
    "usage: renderer --scene FILE --out DIR\n"
    "  The videolized display; normally started by ./afm run inside the run's namespace.\n";

constexpr int kScanReqId = 1;
constexpr int kScanRetryMs = 500;

// matplotlib's afmhot: the usual AFM height colour map.
cv::Mat afmhot_lut()
{
    cv::Mat lut(1, 256, CV_8UC3);
    for (int i = 0; i < 256; ++i) {
        const double x = i / 255.0;
        auto c = [](double v) { return static_cast<uchar>(std::lround(255 * std::clamp(v, 0.0, 1.0))); };
        lut.at<cv::Vec3b>(0, i) = cv::Vec3b(c(2 * x - 1), c(2 * x - 0.5), c(2 * x));  // BGR
    }
    return lut;
}

struct Renderer {
    const afm::Scene &scene;
    lcm::LCM &lc;
    std::string out;
    afm::Heartbeat hb;
    afm::TipShape tip;
    int N;                       // pixels per side
    double px_nm;                // pixel pitch
    double x0, y0;               // field's lower-left corner, nm

    cv::Mat scan;                // the full scan, nm (CV_32F), row 0 = top
    std::vector<bool> got_line;
    int lines_left;
    cv::Mat base;                // scan with the modelled objects erased, nm
    cv::Mat height;              // displayed heights, nm
    cv::Mat color;               // colourised height, BGR, kept up to date locally
    cv::Mat lut = afmhot_lut();
    double z_top = 1;            // colour scale top, nm
    std::map<int, afm::particle_t> drawn;   // what the image shows now, by id
    bool initialised = false;

    afm::fw_tip_t tip_msg{};
    afm::fw_force_t force_msg{};
    int frames_written = 0;
    int64_t last_seq = -1;
    bool sim_done = false;
    cv::VideoWriter video;
    double local_update_s = 0, encode_s = 0;
    int local_updates = 0;

    Renderer(const afm::Scene &s, lcm::LCM &l, std::string o)
        : scene(s), lc(l), out(std::move(o)), hb(l, "renderer")
    {
        if (s.has_effect("tip_convolution")) tip = afm::TipShape{s.probe.tip_radius_nm, s.probe.tip_half_angle_deg};
        N = s.out.image_px;
        px_nm = s.field_nm / N;
        x0 = s.field_center_nm.x - s.field_nm / 2;
        y0 = s.field_center_nm.y - s.field_nm / 2;
        scan = cv::Mat::zeros(N, N, CV_32F);
        got_line.assign(N, false);
        lines_left = N;
    }

    void request_scan(int first, int n)
    {
        afm::scan_req_t r{};
        r.utime = afm::wall_utime();
        r.req_id = kScanReqId;
        r.x0_nm = x0;
        r.y0_nm = y0;
        r.width_nm = r.height_nm = scene.field_nm;
        r.nx = r.ny = N;
        r.first_line = first;
        r.n_lines = n;
        lc.publish(AFM_CH_AFM_SCAN_REQ, &r);
    }

    void request_missing()
    {
        int j = 0;
        while (j < N) {
            if (got_line[j]) { ++j; continue; }
            int k = j;
            while (k < N && !got_line[k]) ++k;
            request_scan(j, k - j);
            j = k;
        }
    }

    void on_line(const lcm::ReceiveBuffer *, const std::string &, const afm::scan_line_t *m)
    {
        if (m->req_id != kScanReqId || m->n != N || m->line < 0 || m->line >= N || got_line[m->line]) return;
        float *row = scan.ptr<float>(N - 1 - m->line);
        for (int i = 0; i < N; ++i) row[i] = static_cast<float>(m->height_nm[i]);
        got_line[m->line] = true;
        --lines_left;
    }

    cv::Rect footprint_rect(const afm::particle_t &p) const
    {
        const double r = afm::sphere_footprint_nm(p.radius_nm, tip) + px_nm;
        const int c0 = static_cast<int>(std::floor((p.x_nm - r - x0) / px_nm));
        const int c1 = static_cast<int>(std::ceil((p.x_nm + r - x0) / px_nm));
        const int r0 = N - 1 - static_cast<int>(std::ceil((p.y_nm + r - y0) / px_nm));
        const int r1 = N - 1 - static_cast<int>(std::floor((p.y_nm - r - y0) / px_nm));
        return cv::Rect(c0, r0, c1 - c0 + 1, r1 - r0 + 1) & cv::Rect(0, 0, N, N);
    }

    // Draw a particle's profile into `img` within `clip` (max with what is there).
    void draw_particle(cv::Mat &img, const afm::particle_t &p, const cv::Rect &clip) const
    {
        const cv::Rect r = footprint_rect(p) & clip;
        for (int row = r.y; row < r.y + r.height; ++row) {
            float *dst = img.ptr<float>(row);
            const double y = y0 + (N - 1 - row + 0.5) * px_nm;
            for (int col = r.x; col < r.x + r.width; ++col) {
                const double x = x0 + (col + 0.5) * px_nm;
                const double z = afm::sphere_profile_nm(p.radius_nm, std::hypot(x - p.x_nm, y - p.y_nm), tip);
                if (z > dst[col]) dst[col] = static_cast<float>(z);
            }
        }
    }

    void colourise(const cv::Rect &r)
    {
        cv::Mat u8;
        height(r).convertTo(u8, CV_8U, 255.0 / z_top);
        cv::Mat bgr;
        cv::cvtColor(u8, bgr, cv::COLOR_GRAY2BGR);
        cv::LUT(bgr, lut, bgr);
        bgr.copyTo(color(r));
    }

    void init_image(const afm::objects_t &objs)
    {
        double zmax;
        cv::minMaxLoc(scan, nullptr, &zmax);
        z_top = std::max(1.0, zmax * 1.1);
        // Erase the objects the model knows from the scan: the substrate (flat
        // glass) is what lies under them.
        base = scan.clone();
        for (const auto &p : objs.particles) {
            const cv::Rect r = footprint_rect(p);
            base(r).setTo(0.0f);
        }
        height = base.clone();
        for (const auto &p : objs.particles) {
            draw_particle(height, p, cv::Rect(0, 0, N, N));
            drawn[p.id] = p;
        }
        color = cv::Mat(N, N, CV_8UC3);
        colourise(cv::Rect(0, 0, N, N));
        initialised = true;
    }

    void local_update(const afm::objects_t &objs)
    {
        const auto t0 = std::chrono::steady_clock::now();
        std::vector<cv::Rect> dirty;
        for (const auto &p : objs.particles) {
            auto it = drawn.find(p.id);
            if (it != drawn.end() && it->second.x_nm == p.x_nm && it->second.y_nm == p.y_nm) continue;
            cv::Rect r = footprint_rect(p);
            if (it != drawn.end()) r |= footprint_rect(it->second);
            dirty.push_back(r);
        }
        for (const auto &p : objs.particles) drawn[p.id] = p;
        for (const cv::Rect &r : dirty) {
            base(r).copyTo(height(r));
            for (const auto &kv : drawn)
                if ((footprint_rect(kv.second) & r).area() > 0) draw_particle(height, kv.second, r);
            colourise(r);
        }
        local_update_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        ++local_updates;
    }

    cv::Point to_px(double x, double y) const
    {
        return cv::Point(static_cast<int>(std::lround((x - x0) / px_nm - 0.5)),
                         static_cast<int>(std::lround(N - 1 - ((y - y0) / px_nm - 0.5))));
    }

    void write_frame(int k)
    {
        const auto t0 = std::chrono::steady_clock::now();
        cv::Mat frame = color.clone();
        // Tip and the measured lateral force (arrow: force on the tip, 1 px per 0.05 nN).
        const cv::Point tp = to_px(tip_msg.tip_nm[0], tip_msg.tip_nm[1]);
        cv::circle(frame, tp, 3, cv::Scalar(255, 200, 0), 1, cv::LINE_AA);
        const cv::Point f(static_cast<int>(std::lround(force_msg.force_nN[0] * 20)),
                          static_cast<int>(std::lround(-force_msg.force_nN[1] * 20)));
        if (f.x || f.y) cv::arrowedLine(frame, tp, tp + f, cv::Scalar(255, 255, 0), 1, cv::LINE_AA, 0, 0.2);
        char text[160];
        std::snprintf(text, sizeof text, "t %.2f s  F %.2f nN", frame_time_s(k),
                      std::hypot(force_msg.force_nN[0], force_msg.force_nN[1]));
        cv::putText(frame, text, cv::Point(4, 14), cv::FONT_HERSHEY_PLAIN, 0.9, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
        std::string flags;
        if (force_msg.flags & afm::fw_force_t::FLAG_CONTACT) flags += "PUSH ";
        if (force_msg.flags & (afm::fw_force_t::FLAG_SAT_SN | afm::fw_force_t::FLAG_SAT_SL)) flags += "SAT ";
        if (force_msg.flags & afm::fw_force_t::FLAG_FX_UNOBSERVABLE) flags += "FX? ";
        if (force_msg.flags & afm::fw_force_t::FLAG_SQUEEZE) flags += "SQUEEZE ";
        if (!flags.empty())
            cv::putText(frame, flags, cv::Point(4, N - 6), cv::FONT_HERSHEY_PLAIN, 0.9, cv::Scalar(0, 255, 255), 1, cv::LINE_AA);
        if (scene.out.png) {
            char name[64];
            std::snprintf(name, sizeof name, "/frames/frame_%05d.png", k);
            if (!cv::imwrite(out + name, frame)) throw std::runtime_error("cannot write " + out + name);
        }
        if (video.isOpened()) video.write(frame);
        encode_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }

    double frame_time_s(int k) const { return afm::frame_utime(scene, k) * 1e-6; }

    void announce(int k, int64_t seq)
    {
        afm::render_frame_t m;
        m.utime = afm::frame_utime(scene, k);
        m.index = k;
        m.seq = seq;
        lc.publish(AFM_CH_RENDER_FRAME, &m);
    }

    void on_tip(const lcm::ReceiveBuffer *, const std::string &, const afm::fw_tip_t *m) { tip_msg = *m; }
    void on_force(const lcm::ReceiveBuffer *, const std::string &, const afm::fw_force_t *m) { force_msg = *m; }

    void on_objects(const lcm::ReceiveBuffer *, const std::string &, const afm::objects_t *m)
    {
        if (!initialised) return;
        if (m->seq <= last_seq) {       // a resend: our announcement may be lost
            if (frames_written > 0) announce(frames_written - 1, last_seq);
            return;
        }
        last_seq = m->seq;
        const int due = afm::frames_due(scene, m->utime);
        if (due <= frames_written) return;
        local_update(*m);
        while (frames_written < due) write_frame(frames_written++);
        announce(frames_written - 1, m->seq);
        hb.maybe_send("running", m->seq, m->utime);
    }

    void on_heartbeat(const lcm::ReceiveBuffer *, const std::string &, const afm::heartbeat_t *m)
    {
        if ((m->name == "sim_afm" && m->state == "done") || (m->name == "launcher" && m->state == "stop")) sim_done = true;
    }

    // The firmware's initial model comes with its first FW_OBJECTS; before the
    // run starts the model is the scene's object list (as the operator marked
    // it on the first scan), which is what the firmware is initialised with.
    afm::objects_t scene_objects() const
    {
        afm::objects_t o{};
        for (const auto &p : scene.particles) {
            afm::particle_t q{};
            q.id = p.id;
            q.x_nm = p.x_nm;
            q.y_nm = p.y_nm;
            q.radius_nm = p.radius_nm;
            o.particles.push_back(q);
        }
        o.n_particles = static_cast<int32_t>(o.particles.size());
        return o;
    }
};

}  // namespace

int main(int argc, char **argv)
{
    std::string scene_path, out_dir;
    for (int i = 1; i < argc; ++i) {
        std::string a = argv[i];
        if (a == "--scene" && i + 1 < argc) scene_path = argv[++i];
        else if (a == "--out" && i + 1 < argc) out_dir = argv[++i];
        else if (a == "-h" || a == "--help") { std::fputs(kUsage, stdout); return 0; }
        else { std::fprintf(stderr, "renderer: unknown argument '%s'\n%s", a.c_str(), kUsage); return 2; }
    }
    if (scene_path.empty() || out_dir.empty()) { std::fputs(kUsage, stderr); return 2; }
    try {
        const afm::Scene scene = afm::load_scene(scene_path);
        std::filesystem::create_directories(out_dir + "/frames");
        auto lc = afm::open_bus();
        Renderer r(scene, *lc, out_dir);
        lc->subscribe(AFM_CH_AFM_SCAN_LINE, &Renderer::on_line, &r)->setQueueCapacity(afm::kQueueCapacity);
        lc->subscribe(AFM_CH_FW_TIP, &Renderer::on_tip, &r)->setQueueCapacity(afm::kQueueCapacity);
        lc->subscribe(AFM_CH_FW_FORCE, &Renderer::on_force, &r)->setQueueCapacity(afm::kQueueCapacity);
        lc->subscribe(AFM_CH_FW_OBJECTS, &Renderer::on_objects, &r)->setQueueCapacity(afm::kQueueCapacity);
        lc->subscribe(AFM_CH_AFM_HEARTBEAT, &Renderer::on_heartbeat, &r)->setQueueCapacity(afm::kQueueCapacity);

        // The full scan first (re-requesting lines lost on the way).
        r.hb.send("starting", -1, 0, "scanning");
        r.request_scan(0, r.N);
        auto last_req = std::chrono::steady_clock::now();
        while (r.lines_left > 0) {
            lc->handleTimeout(50);
            if (r.sim_done) return 3;
            if (std::chrono::steady_clock::now() - last_req > std::chrono::milliseconds(kScanRetryMs)) {
                r.request_missing();
                last_req = std::chrono::steady_clock::now();
                r.hb.send("starting", -1, 0, "scan lines left: " + std::to_string(r.lines_left));
            }
        }
        cv::imwrite(out_dir + "/scan_initial.png", [&] {
            cv::Mat u8;
            double zmax;
            cv::minMaxLoc(r.scan, nullptr, &zmax);
            r.scan.convertTo(u8, CV_8U, 255.0 / std::max(1.0, zmax * 1.1));
            cv::Mat bgr;
            cv::cvtColor(u8, bgr, cv::COLOR_GRAY2BGR);
            cv::LUT(bgr, r.lut, bgr);
            return bgr;
        }());
        r.init_image(r.scene_objects());
        if (scene.out.video != "none") {
            const bool mp4 = scene.out.video == "mp4";
            const std::string path = out_dir + (mp4 ? "/video.mp4" : "/video.avi");
            r.video.open(path, mp4 ? cv::VideoWriter::fourcc('m', 'p', '4', 'v') : cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                         scene.frame_rate_hz, cv::Size(r.N, r.N));
            if (!r.video.isOpened()) throw std::runtime_error("cannot open video writer for " + path);
        }
        while (!r.sim_done) {
            r.hb.maybe_send(r.last_seq < 0 ? "ready" : "running", r.last_seq, 0, r.last_seq < 0 ? 200000 : 1000000);
            lc->handleTimeout(100);
        }
        r.video.release();
        std::ofstream rep(out_dir + "/renderer_report.json");
        rep << "{\"frames\": " << r.frames_written << ", \"local_updates\": " << r.local_updates
            << ", \"local_update_ms_mean\": " << (r.local_updates ? 1e3 * r.local_update_s / r.local_updates : 0)
            << ", \"frame_write_ms_mean\": " << (r.frames_written ? 1e3 * r.encode_s / r.frames_written : 0) << "}\n";
        r.hb.send("done", r.last_seq, 0);
        return 0;
    } catch (const afm::SceneError &e) {
        std::fprintf(stderr, "%s\n", e.what());
        return 2;
    } catch (const std::exception &e) {
        std::fprintf(stderr, "renderer: %s\n", e.what());
        return 1;
    }
}
