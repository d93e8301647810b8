// Renderer: the videolized display, off-screen (renderer/main.cpp runs it). Starts from a full scan,
// updates the image locally from the firmware's object states (display.hpp:
// particles, wires and lithography trenches from FW_STATE's objects; the scene's
// wires as laid until the firmware publishes wires),
// writes a PNG per frame and a video at the scene's frame rate (on a thread
// of its own: frame_writer.hpp), and announces each frame
// on RENDER_FRAME (the simulator runs at most 2 frames ahead of
// it, and waits for it at the frames where it asks for a scan:
// afm::frames_to_wait_for). With --view-frames it also offers each frame
// to a person watching (view_frames.hpp: VIEW_FRAME, never waited for).
//
// At the last frame it asks the simulator for a fresh full scan and compares
// it with what it displays (fidelity.hpp), the paper's check, before
// announcing that frame; the simulator serves the scan while it waits. The
// frame itself is composed (and offered to the page) before the scan: the
// scan changes nothing it shows.
// Writes: frames/*.png, video.mp4|avi, contact_sheet.png, scan_initial.png,
// *.gsf (Gwyddion Simple Field) of the scans and the final display,
// fidelity_diff.png, fidelity.json, renderer_report.json.
#pragma once

#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include <chrono>
#include <deque>
#include <map>
#include <optional>
#include <set>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "afm/fw_state_t.hpp"
#include "afm/heartbeat_t.hpp"
#include "afm/haptic_force_t.hpp"
#include "afm/object_fix_t.hpp"
#include "afm/objects_t.hpp"
#include "afm/render_frame_t.hpp"
#include "afm/scan_line_t.hpp"
#include "bus.hpp"
#include "inbox.hpp"
#include "display.hpp"
#include "fidelity.hpp"
#include "fidelity_figure.hpp"
#include "frame_overlay.hpp"
#include "frame_writer.hpp"
#include "view_frames.hpp"
#include "objects_view.hpp"
#include "pattern.hpp"
#include "process.hpp"
#include "png_file.hpp"
#include "scan_client.hpp"
#include "scene.hpp"
#include "fw_drift.h"

namespace afm::render {

constexpr int kInitialScan = 1, kFinalScan = 2, kLocalScanBase = 100;
constexpr int kFixRetryMs = 200;
constexpr int64_t kProgressPeriodUs = 250000;   // heartbeats the launcher's progress line reads
constexpr int kScanRetryMs = 500;
// The renderer's inbox takes the bus in batches this far apart, on a thread
// of its own (inbox.hpp, batched), so that a block's display messages cost
// one wake-up, not one each, and a frame's PNG or the fidelity check loses
// none of them (docs/bus.md, "The latency model"; ./afm bench bus measures
// it). A frame is announced at most this much later than it could be.
constexpr int kBatchUs = 500;
constexpr double kFidelitySearch_nm = 40.0;    // how far from its model position an object is looked for
constexpr double kFidelityTarget_nm = 5.0;     // the target: every object within 5 nm
constexpr double kHandGaugeThresholds = 4.0;   // the hand's gauge: its circle is this many feel thresholds

// One channel's messages by block (FW_STATE, HAPTIC_FORCE), so that a
// frame shows those of its own block: the channels come at different times
// (HAPTIC_FORCE at once; FW_STATE, whose objects make a frame due, aside, a
// batch later, unless the operator plans: common/aside.hpp). At most kKept
// blocks are kept; taking a block lets the older ones go.
template <class M> class BySeq
{
public:
    static constexpr std::size_t kKept = 4096;

    // The newest block that came, or -1.
    int64_t newest() const { return by_seq_.empty() ? -1 : by_seq_.rbegin()->first; }

    // A block older than the newest is refused; one sent again replaces the first.
    afm::Reject put(const M &m)
    {
        if (m.seq < newest()) return afm::Reject::seq_past;
        by_seq_[m.seq] = m;
        while (by_seq_.size() > kKept) by_seq_.erase(by_seq_.begin());
        return afm::Reject::none;
    }

    // The latest message of a block up to `seq` (a zero message of block -1
    // before the first).
    M at(int64_t seq)
    {
        auto it = by_seq_.upper_bound(seq);
        if (it == by_seq_.begin()) {
            M none{};
            none.seq = -1;
            return none;
        }
        --it;
        by_seq_.erase(by_seq_.begin(), it);
        return it->second;
    }

private:
    std::map<int64_t, M> by_seq_;
};

// The firmware's wires and trenches as the display draws them.
inline afm::DisplayWire display_wire(const afm::wire_t &w)
{
    afm::DisplayWire d{w.id, w.diameter_nm, {}, 0.5 * w.diameter_nm - w.axis_z_nm};
    for (int i = 0; i < w.n; ++i) d.nodes_nm.emplace_back(w.x_nm[i], w.y_nm[i]);
    return d;
}

inline afm::DisplayTrench display_trench(const afm::trench_t &t)
{
    afm::DisplayTrench d{t.id, {}};
    for (int i = 0; i < t.n; ++i) d.points.push_back({t.x_nm[i], t.y_nm[i], t.depth_nm[i], t.width_nm[i]});
    return d;
}

struct Renderer {
    const afm::Scene &scene;
    lcm::LCM &lc;
    std::string out;
    afm::Heartbeat hb;
    afm::Field field;
    afm::TipShape tip;
    afm::Display display;
    afm::ScanClient scan;
    cv::Rect scan_px;            // the scan's region, in display pixels (same pitch)
    cv::Mat scan_lateral;        // the scan's lateral signal S_l, V, row 0 at the top (its GSF: *_lateral.gsf)
    int64_t scan_utime = 0;      // the simulated time of the scan's latest line, microseconds
    bool started = false;        // the initial scan is in and the display set up

    BySeq<afm::fw_state_t> states;
    BySeq<afm::haptic_force_t> hands;
    afm::ObjectsView objects;           // FW_STATE's objects, whole
    afm::DisplayModel model;
    const afm::LeverView lever = afm::lever_view(scene.probe.scan_angle_deg);
    int frames_written = 0;
    int64_t last_seq = -1;       // the latest block whose objects the renderer took
    int64_t shown_seq = -1;      // the block whose objects, force, tip and hand the frames show
    // Frames fallen due at a block, waiting while a scan pauses the frames
    // (draw_ready): the block, the frames due by its end, its objects (none
    // when the model is already set: after a fix).
    struct Due {
        int64_t seq;
        int due;
        std::optional<afm::objects_t> objects;
    };
    std::deque<Due> due_queue;
    int due_queued = 0;          // frames due so far, drawn or queued
    // Frames drawn with a state (force, tip) that is not of their objects'
    // block: none, as FW_STATE carries both (a check of BySeq).
    int64_t frames_mixed_blocks = 0;
    const int64_t blocks_ahead = static_cast<int64_t>(std::ceil(scene.block_hz)) + 2;
    bool sim_done = false;
    bool final_pending = false;  // waiting for the final scan before the last frame
    int local_next = 0;          // next scene local scan to take
    int local_pending = -1;      // local scan being taken (index), or -1
    double local_size_nm = 0;    // the side of the local scan being taken
    bool local_wide = false;     // it is the wider retry of a scan that missed its object
    int fix_awaited = 0;         // object fix sent, waiting for the firmware's acknowledgement
    int fixes_sent = 0;
    double fw_drift_nm[2] = {0, 0};   // the firmware's drift estimate, from FW_STATE's objects
    bool fix_on_landmark = false;
    afm::object_fix_t fix_msg{};
    std::chrono::steady_clock::time_point fix_sent;
    int due_pending = 0;         // frames due by the block being drawn (continue_frames draws up to it; a scan pauses it)
    nlohmann::json local_scans = nlohmann::json::array();
    std::vector<int> writer_cpus;            // --writer-cpus
    std::unique_ptr<afm::FrameWriter> writer;   // the frames' files (begin())
    std::unique_ptr<afm::ViewFrames> view;      // the frames for a page (--view-frames), or none
    int64_t objects_seq = -1;    // the latest block whose FW_STATE came
    // blocks whose FW_STATE never came (lost on the bus): those skipped over
    // and not come since (kept up to kMaxGaps; past that, only counted)
    static constexpr std::size_t kMaxGaps = 100000;
    std::set<int64_t> objects_gaps;
    int64_t objects_gaps_uncounted = 0;
    int total_frames;            // the run's frames: the scene's, or fewer when the planner finishes early
    std::vector<int> sheet_at;   // frame indices for the contact sheet
    std::map<int, cv::Mat> sheet;   // frames kept for the sheet, by index
    std::vector<std::pair<int, cv::Mat>> composed;   // frames composed, their files not yet written
    double update_s = 0, compose_s = 0;
    long touched_px = 0;
    nlohmann::json fidelity;

    Renderer(const afm::Scene &s, lcm::LCM &l, std::string o)
        : scene(s), lc(l), out(std::move(o)), hb(l, "renderer"),
          field{s.field_center_nm.x - s.field_nm / 2, s.field_center_nm.y - s.field_nm / 2, s.field_nm, s.out.image_px},
          tip(s.has_effect("tip_convolution") ? afm::TipShape{s.probe.tip_radius_nm, s.probe.tip_half_angle_deg} : afm::TipShape{}),
          display(field, tip), scan(l), total_frames(s.total_frames())
    {
        display.set_trails(s.out.trails);
        pick_sheet();
        for (const auto &p : s.particles) model.particles.push_back({p.id, p.x_nm, p.y_nm, p.radius_nm});
        for (const auto &w : s.wires) model.wires.push_back({w.id, w.diameter_nm, {{w.x0_nm, w.y0_nm}, {w.x1_nm, w.y1_nm}}});
    }

    // The contact sheet's frames: evenly over the run's frames.
    void pick_sheet()
    {
        const int K = total_frames, M = std::min(scene.out.contact_sheet_frames, K);
        sheet_at.clear();
        for (int i = 0; i < M; ++i) sheet_at.push_back(M == 1 ? 0 : static_cast<int>(std::lround(i * (K - 1.0) / (M - 1))));
    }

    void start_scan(int req, const cv::Rect &region)
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

    // A line of the scan being taken: its lateral signal and time kept
    // beside the heights the scan client keeps (same rows: line 0 at the bottom).
    void keep_line(const afm::scan_line_t &m)
    {
        if (!scan.busy() || m.req_id != scan.id() || m.n != scan_lateral.cols || m.line < 0 || m.line >= scan_lateral.rows ||
            static_cast<int>(m.lat_v.size()) != m.n)
            return;
        float *row = scan_lateral.ptr<float>(scan_lateral.rows - 1 - m.line);
        for (int i = 0; i < m.n; ++i) row[i] = static_cast<float>(m.lat_v[static_cast<std::size_t>(i)]);
        scan_utime = std::max(scan_utime, m.utime);
    }

    // The run's metadata a GSF file carries (docs/data.md): the scene, the
    // loads, the scan angle, the simulated and wall-clock time, what it shows.
    afm::GsfMeta gsf_meta(const std::string &channel, int64_t utime, const std::string &source, int source_id) const
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

    // A scan's files: its heights, and its lateral signal where every line brought one.
    void write_scan_gsf(const std::string &name, const cv::Rect &region)
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

    void retry_scan() { scan.retry(kScanRetryMs); }

    // A local scan a person asked for (operator.mode browser; the operator
    // asks, kPageScanReqBase and up): its lines kept, the scan pasted into
    // the display once whole (its rectangle from its first line, on the
    // display's pixels; a line of another geometry is refused).
    struct PageScan {
        cv::Rect where;
        cv::Mat heights;
        std::vector<bool> got;
        int left = 0;
    };
    static constexpr std::size_t kPageScansOpen = 4;
    std::map<int, PageScan> page_open;
    int page_pasted = 0;

    afm::Reject page_line(const afm::scan_line_t &m)
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
            display.paste_scan(p.heights, p.where);
            ++page_pasted;
            page_open.erase(it);
        }
        return afm::Reject::none;
    }

    afm::Reject on_line(const afm::scan_line_t &m)
    {
        if (m.req_id >= afm::kPageScanReqBase) return page_line(m);
        keep_line(m);
        if (!scan.on_line(m)) return afm::Reject::none;   // a line of another client's scan, or one already here
        if (scan.id() == kFinalScan && final_pending) finish_last_frame();
        else if (local_pending >= 0 && scan.id() == kLocalScanBase + local_pending) local_scan_done();
        return afm::Reject::none;
    }

    // A message of block `seq` (FW_STATE, HAPTIC_FORCE
    // n come with block n): its time must be that block's end, and it
    // cannot be more than a simulated second past the last block the
    // renderer took objects from (messages are taken in the order sent, so
    // the next one is a block or so past it).
    afm::Reject block_message(int64_t seq, int64_t utime) const
    {
        if (seq < -1) return afm::Reject::out_of_range;
        if (seq > last_seq + blocks_ahead) return afm::Reject::seq_future;
        if (seq >= 0 && utime != afm::block_end_utime(scene, seq)) return afm::Reject::out_of_range;
        return afm::Reject::none;
    }

    // The display's heights at frame k as a GSF file.
    void write_display_gsf(const std::string &name, const cv::Mat &h, int k)
    {
        std::string err;
        if (!afm::write_gsf(out + "/" + name + ".gsf", h, field, cv::Rect(0, 0, h.cols, h.rows), name, &err,
                            gsf_meta("Height", afm::frame_utime(scene, k), "Frame", k)))
            throw std::runtime_error(err);
    }

    // The frames' writer, its video encoder starting on the writer's thread
    // while the full scan runs (main.cpp opens it before the scan).
    void open_writer()
    {
        writer = std::make_unique<afm::FrameWriter>(out, scene.out.png, scene.out.video, scene.frame_rate_hz, field.px, writer_cpus);
    }

    void begin()
    {
        display.start(scan.heights(), model);
        afm::write_png(out + "/scan_initial.png", display.colourise(scan.heights()));
        write_scan_gsf("scan_initial", cv::Rect(0, 0, field.px, field.px));
        if (!writer) open_writer();
        writer->wait_open();   // the encoder up before the first block (frame_writer.hpp)
        started = true;
    }

    // Composes frame k; its files are written after the frame is announced
    // (write_composed), so the simulator goes on while they are encoded.
    void write_frame(int k)
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

    // What the page draws over frame k (view_frame_t), from the state and
    // overlay the frame was composed with.
    afm::view_frame_t view_state(int k, const afm::fw_state_t &state, const afm::Overlay &o) const
    {
        afm::view_frame_t m{};
        m.utime = afm::frame_utime(scene, k);
        m.index = k;
        m.frames_total = total_frames;
        m.seq = shown_seq;
        m.width = m.height = field.px;
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

    // The frames composed and announced up to frame `upto`, to the writer
    // (their files: PNG and video, in order).
    void write_composed(int upto)
    {
        while (!composed.empty() && composed.front().first <= upto) {   // the last frame waits for its check (continue_frames)
            writer->write(composed.front().first, std::move(composed.front().second));
            composed.erase(composed.begin());
        }
    }

    void announce(int k, int64_t seq)
    {
        afm::render_frame_t m;
        m.utime = afm::frame_utime(scene, k);
        m.index = k;
        m.seq = seq;
        afm::publish(lc, AFM_CH_RENDER_FRAME, m);
        write_composed(k);
    }

    // The card's state of a block: its force and tip kept by block, its
    // objects taken (take_objects), which may make frames due.
    afm::Reject on_state(const afm::fw_state_t &m)
    {
        if (const afm::Reject r = block_message(m.seq, m.utime); r != afm::Reject::none) return r;
        if (m.objects.seq != m.seq || m.objects.utime != m.utime) return afm::Reject::out_of_range;
        // A block older than the newest (the bus reordered them) is not kept
        // for the frames (BySeq), but its objects are taken: the next
        // block's lists only what changed since it (objects_t.lcm).
        states.put(m);
        return take_objects(m.objects);
    }
    afm::Reject on_haptic(const afm::haptic_force_t &m)
    {
        if (const afm::Reject r = block_message(m.seq, m.utime); r != afm::Reject::none) return r;
        const afm::Reject r = hands.put(m);
        if (view && r == afm::Reject::none) view->sample(m);
        return r;
    }

    void set_model(const afm::objects_t &m)
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

    afm::Reject take_objects(const afm::objects_t &msg)
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

    // A block whose objects never came: the simulator no longer waits at
    // every frame, so a frame due at a lost block is drawn from a later one
    // (renderer_report.json: objects_blocks_missed; docs/bus.md). A block the bus
    // handed over late, after a later one, is not missed.
    void count_objects_block(int64_t seq)
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
    int64_t objects_missed() const { return static_cast<int64_t>(objects_gaps.size()) + objects_gaps_uncounted; }

    void objects_frames(const afm::objects_t *m)
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

    // Draws the frames queued, in order, until a scan pauses the frames.
    void draw_ready()
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

    // Writes the frames due, pausing for a scheduled local scan or, before
    // the last frame, for the final scan (the simulator waits meanwhile).
    void continue_frames()
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

    // The modelled position of a particle, or of a landmark (its scene
    // position carried along by the firmware's drift). True for a landmark.
    bool landmark_or_particle_at(int id, double *x, double *y) const
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

    void start_local_scan(int i, double size_nm = 0)
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

    // The card's drift correction limit (nm): the scene's, or the firmware's default.
    double drift_limit_nm() const
    {
        return scene.fw_cal.drift_max_step_nm.value_or(FW_DRIFT_MAX_STEP_DEFAULT_PM * 1e-3);
    }

    void local_scan_done()
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
                              {"wide", local_wide}};
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
        rec["found"] = true;
        rec["model_nm"] = {mx, my};
        rec["scan_nm"] = {sx, sy};
        local_scans.push_back(rec);
        fix_msg.utime = afm::frame_utime(scene, frames_written);
        fix_msg.fix_id = ++fixes_sent;
        fix_msg.object_id = ls.around_id;
        fix_msg.scan_x_nm = sx;
        fix_msg.scan_y_nm = sy;
        fix_awaited = fix_msg.fix_id;
        send_fix();
    }

    void send_fix()
    {
        afm::publish(lc, AFM_CH_HOST_OBJECT_FIX, fix_msg);
        fix_sent = std::chrono::steady_clock::now();
    }

    void retry_fix()
    {
        if (fix_awaited > 0 && std::chrono::steady_clock::now() - fix_sent > std::chrono::milliseconds(kFixRetryMs)) send_fix();
    }

    // The final scan is in: the last frame (composed before it) is announced
    // at once, so that the simulator runs its last blocks while the display
    // is compared with the scan and the files are written.
    void finish_last_frame()
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
        if (scene.op.plan.enabled) fidelity["placement"] = placement_json();
        afm::write_report(out + "/fidelity.json", fidelity);
    }

    // The planner's result in the fresh scan: each target site (sample
    // coordinates, moved by the firmware's drift) and the particle the scan
    // shows near it; each rod against its target pose.
    nlohmann::json placement_json() const
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
            const afm::PlacementCheck c = afm::check_sites(scan.heights(), field, at, afm::sphere_footprint_nm(r, tip) * 0.5 + ps.tolerance_nm,
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

    afm::Reject on_heartbeat(const afm::heartbeat_t &m)
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
};

// Writes contact_sheet.png: the frames picked over the run, those not kept in memory
// (picked again after an early end) read back from frames/.
inline void write_contact_sheet(Renderer &r, const afm::Scene &scene, const std::string &out_dir)
{
    std::vector<cv::Mat> tiles;
    for (int k : r.sheet_at) {
        if (k >= r.frames_written) continue;
        if (r.sheet.count(k)) {
            tiles.push_back(r.sheet[k]);
        } else if (scene.out.png) {
            char name[64];
            std::snprintf(name, sizeof name, "/frames/frame_%05d.png", k);
            const cv::Mat f = cv::imread(out_dir + name);
            if (!f.empty()) tiles.push_back(f);
        }
    }
    if (!tiles.empty()) {
        const int cols = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(tiles.size()))));
        afm::write_png(out_dir + "/contact_sheet.png", afm::contact_sheet(tiles, cols));
    }
}

// renderer_report.json: the frames, what they cost, what the renderer refused.
inline nlohmann::json report_json(const Renderer &r, const afm::Scene &scene, const nlohmann::json &rejected)
{
    return {{"frames", r.frames_written},
            {"objects_blocks_missed", r.objects_missed()},
            {"frames_mixed_blocks", r.frames_mixed_blocks},
            {"frames_expected", r.total_frames},
            {"image_px", scene.out.image_px},
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
            {"label_cap_px", afm::frame_text(scene.out.image_px).cap_px},
            {"fidelity_label_cap_px", afm::fidelity_figure_text().cap_px},
            {"pixels_updated", r.touched_px},
            {"local_scans", r.local_scans},
            {"page_scans_pasted", r.page_pasted},   // a person's local scans (operator.mode browser)
            {"view", r.view ? r.view->report() : nlohmann::json(nullptr)},
            {"rejected", rejected}};
}


}  // namespace afm::render
