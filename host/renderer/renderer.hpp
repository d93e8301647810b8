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
#include "scan_dewarp.hpp"
#include "lockstep.hpp"
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
// batch later, unless the operator plans: bus/aside.hpp). At most kKept
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
    afm::Heartbeat &hb;   // the process's one (its Lifecycle's)
    afm::Field field;
    afm::TipShape tip;
    afm::Display display;
    afm::ScanClient scan;
    // The card's scanner model, followed from FW_STATE's drive: every scan
    // de-warped by it (the full and local scans through the scan client,
    // their lateral signal and a person's local scans here).
    afm::ScanDewarp dewarp;
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

    Renderer(const afm::Scene &s, lcm::LCM &l, afm::Heartbeat &h, std::string o)
        : scene(s), lc(l), out(std::move(o)), hb(h),
          field{s.field_center_nm.x - s.field_nm / 2, s.field_center_nm.y - s.field_nm / 2, s.field_nm, s.out.image_px},
          tip(s.has_effect("tip_convolution") ? afm::TipShape{s.probe.tip_radius_nm, s.probe.tip_half_angle_deg} : afm::TipShape{}),
          display(field, tip), scan(l), dewarp(s), total_frames(s.total_frames())
    {
        scan.set_dewarp(&dewarp);
        display.set_trails(s.out.trails);
        pick_sheet();
        for (const auto &p : s.particles) model.particles.push_back({p.id, p.x_nm, p.y_nm, p.radius_nm});
        for (const auto &w : s.wires) model.wires.push_back({w.id, w.diameter_nm, {{w.x0_nm, w.y0_nm}, {w.x1_nm, w.y1_nm}}});
    }

    // The contact sheet's frames: evenly over the run's frames.
    void pick_sheet();

    void start_scan(int req, const cv::Rect &region);

    // A line of the scan being taken: its lateral signal and time kept
    // beside the heights the scan client keeps (same rows: line 0 at the bottom).
    void keep_line(const afm::scan_line_t &m);

    // The run's metadata a GSF file carries (docs/data.md): the scene, the
    // loads, the scan angle, the simulated and wall-clock time, what it shows.
    afm::GsfMeta gsf_meta(const std::string &channel, int64_t utime, const std::string &source, int source_id) const;

    // A scan's files: its heights, and its lateral signal where every line brought one.
    void write_scan_gsf(const std::string &name, const cv::Rect &region);

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

    afm::Reject page_line(const afm::scan_line_t &m);

    afm::Reject on_line(const afm::scan_line_t &m);

    // A message of block `seq` (FW_STATE, HAPTIC_FORCE
    // n come with block n): its time must be that block's end, and it
    // cannot be more than a simulated second past the last block the
    // renderer took objects from (messages are taken in the order sent, so
    // the next one is a block or so past it).
    afm::Reject block_message(int64_t seq, int64_t utime) const;

    // The display's heights at frame k as a GSF file.
    void write_display_gsf(const std::string &name, const cv::Mat &h, int k);

    // The frames' writer, its video encoder starting on the writer's thread
    // while the full scan runs (main.cpp opens it before the scan).
    void open_writer();

    void begin();

    // Composes frame k; its files are written after the frame is announced
    // (write_composed), so the simulator goes on while they are encoded.
    void write_frame(int k);

    // What the page draws over frame k (view_frame_t), from the state and
    // overlay the frame was composed with.
    afm::view_frame_t view_state(int k, const afm::fw_state_t &state, const afm::Overlay &o) const;

    // The frames composed and announced up to frame `upto`, to the writer
    // (their files: PNG and video, in order).
    void write_composed(int upto);

    void announce(int k, int64_t seq);

    // The card's state of a block: its force and tip kept by block, its
    // objects taken (take_objects), which may make frames due.
    afm::Reject on_state(const afm::fw_state_t &m);
    afm::Reject on_haptic(const afm::haptic_force_t &m);

    void set_model(const afm::objects_t &m);

    afm::Reject take_objects(const afm::objects_t &msg);

    // A block whose objects never came: the simulator no longer waits at
    // every frame, so a frame due at a lost block is drawn from a later one
    // (renderer_report.json: objects_blocks_missed; docs/bus.md). A block the bus
    // handed over late, after a later one, is not missed.
    void count_objects_block(int64_t seq);
    int64_t objects_missed() const { return static_cast<int64_t>(objects_gaps.size()) + objects_gaps_uncounted; }

    void objects_frames(const afm::objects_t *m);

    // Draws the frames queued, in order, until a scan pauses the frames.
    void draw_ready();

    // Writes the frames due, pausing for a scheduled local scan or, before
    // the last frame, for the final scan (the simulator waits meanwhile).
    void continue_frames();

    // The modelled position of a particle, or of a landmark (its scene
    // position carried along by the firmware's drift). True for a landmark.
    bool landmark_or_particle_at(int id, double *x, double *y) const;

    void start_local_scan(int i, double size_nm = 0);

    // The card's drift correction limit (nm): the scene's, or the firmware's default.
    double drift_limit_nm() const;

    void local_scan_done();

    void send_fix();

    void retry_fix();

    // The final scan is in: the last frame (composed before it) is announced
    // at once, so that the simulator runs its last blocks while the display
    // is compared with the scan and the files are written.
    void finish_last_frame();

    // The planner's result in the fresh scan: each target site (sample
    // coordinates, moved by the firmware's drift) and the particle the scan
    // shows near it; each rod against its target pose.
    nlohmann::json assembly_json() const;

    afm::Reject on_heartbeat(const afm::heartbeat_t &m);
};

// What a scan's de-warp did (fidelity.json "dewarp", each local scan's
// record): whether the card's model placed its pixels, the largest move,
// the model's block end and the scan's, s.
nlohmann::json dewarp_json(const afm::DewarpNote &n);

// Writes contact_sheet.png: the frames picked over the run, those not kept in memory
// (picked again after an early end) read back from frames/.
void write_contact_sheet(Renderer &r, const afm::Scene &scene, const std::string &out_dir);

// renderer_report.json: the frames, what they cost, what the renderer refused.
nlohmann::json report_json(const Renderer &r, const afm::Scene &scene, const nlohmann::json &rejected);

}  // namespace afm::render
