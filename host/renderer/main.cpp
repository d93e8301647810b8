// renderer: the videolized display's process (renderer.hpp: the Renderer,
// what it draws and when). Reads the command line, takes the first scan,
// serves the bus until the run is over, and writes the contact sheet and
// renderer_report.json.
#include <malloc.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "lockstep.hpp"
#include "aside.hpp"
#include "run_process.hpp"
#include "renderer.hpp"

namespace {

// The renderer's command line and its one check of each option (command_line.hpp).
struct Options {
    std::string scene_path, out_dir;
    std::vector<int> writer_cpus;
    bool view_frames = false;
};

const afm::Process<Options> kProcess = {
    {"renderer",
    "usage: renderer --scene FILE --out DIR [options]\n"
    "  The videolized display; normally started by ./afm run inside the run's namespace.\n",
    {
        {{"--scene", "FILE", nullptr, nullptr, true}, afm::cli::text(&Options::scene_path)},
        {{"--out", "DIR", nullptr, nullptr, true}, afm::cli::text(&Options::out_dir)},
        {{"--writer-cpus", "LIST", "options:",
          "the CPUs (\"0-1\") the frame writer's thread may use\n"
          "(host/renderer/frame_writer.hpp; the launcher passes every CPU of the run)"},
         afm::cli::cpus(&Options::writer_cpus)},
        {{"--view-frames", nullptr, "options:",
          "also publish each frame for a page on VIEW_FRAME (view_frames.hpp;\n"
          "the launcher passes it with --view)"},
         afm::cli::flag(&Options::view_frames)},
    }},
    {AFM_CH_AFM_SCAN_LINE, AFM_CH_FW_STATE, AFM_CH_HAPTIC_FORCE, AFM_CH_AFM_HEARTBEAT},
    {AFM_CH_AFM_SCAN_REQ, AFM_CH_RENDER_FRAME, AFM_CH_HOST_OBJECT_FIX, AFM_CH_VIEW_FRAME},
    [](const Options &o) { return o.out_dir + "/renderer_report.json"; }};

using namespace afm::render;

// SIGTERM or SIGINT (the launcher stopping a run): the renderer ends its
// loop as when the run is over, so that the video is closed and opens (an
// interrupted run left a 44-byte mp4 without its moov atom) and the frames,
// sheet and report written so far are kept.
volatile sig_atomic_t g_stop = 0;
extern "C" void on_stop(int) { g_stop = 1; }

}  // namespace

// Serves the bus until the run is over (or the launcher stops it): draws
// the frames, asks for the scans and sends the fixes.
static void serve(Renderer &r, afm::Inbox &inbox, afm::Lifecycle &life)
{
    life.serve([&] { return afm::Progress{r.last_seq >= 0, r.last_seq, 0}; },
               [&](int ms) {
                   // what has come (the inbox's thread takes the bus in batches, kBatchUs apart)
                   if (inbox.handle(ms) > 0)
                       while (inbox.handle(0) > 0) {}
                   if (r.final_pending || r.local_pending >= 0) r.retry_scan();
                   r.retry_fix();
                   r.draw_ready();   // frames queued while a scan paused them
               },
               [&] { return r.sim_done || g_stop; }, 50);
}

// A frame (768 kB at 512 px) comes from the heap and goes back to it, not
// to a mapping of its own that the kernel zeroes page by page when it is
// composed and unmaps when it is written (and then flushes from the other
// CPUs this process ran on). The heap keeps at most the frames the writer
// holds (FrameWriter::kMaxPending).
static void frames_from_the_heap()
{
    mallopt(M_MMAP_THRESHOLD, 16 << 20);
    mallopt(M_TRIM_THRESHOLD, 128 << 20);
}

int main(int argc, char **argv)
{
    frames_from_the_heap();
    return afm::run_process(kProcess, argc, argv, [](const Options &opt, afm::Lifecycle &life) {
        const afm::Scene scene = afm::load_scene(opt.scene_path);
        std::filesystem::create_directories(opt.out_dir + "/frames");
        lcm::LCM &lc = life.bus();
        Renderer r(scene, lc, life.heartbeat(), opt.out_dir);
        r.writer_cpus = opt.writer_cpus;
        // the strip chart: about 250 samples a simulated second; the
        // encoding on the renderer's own CPUs (the observers', view_frames.hpp)
        if (opt.view_frames) r.view = std::make_unique<afm::ViewFrames>(std::max(1, static_cast<int>(scene.block_hz / 250)), std::vector<int>{});
        afm::Inbox inbox(&lc, kBatchUs);   // batched: its thread takes the bus every kBatchUs
        inbox.on<afm::scan_line_t>(AFM_CH_AFM_SCAN_LINE, [&](const afm::scan_line_t &m) { return r.on_line(m); });
        inbox.on<afm::fw_state_t>(AFM_CH_FW_STATE, [&](const afm::fw_state_t &m) { return r.on_state(m); });
        inbox.on<afm::haptic_force_t>(AFM_CH_HAPTIC_FORCE, [&](const afm::haptic_force_t &m) { return r.on_haptic(m); });
        inbox.on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [&](const afm::heartbeat_t &m) { return r.on_heartbeat(m); });
        life.check_subscriptions(inbox.channels());

        struct sigaction sa {};
        sa.sa_handler = on_stop;
        sigemptyset(&sa.sa_mask);
        sigaction(SIGTERM, &sa, nullptr);
        sigaction(SIGINT, &sa, nullptr);
        // The full scan first, while the frames' video encoder starts.
        r.open_writer();
        life.starting("scanning");
        r.start_scan(kInitialScan, cv::Rect(0, 0, r.field.px, r.field.px));
        while (r.scan.busy()) {
            inbox.handle(50);
            if (r.sim_done || g_stop) return static_cast<int>(afm::kExitRunOverEarly);
            r.retry_scan();
        }
        r.begin();
        const auto report = life.report_from([&] { return report_json(r, scene, inbox.report()); });
        serve(r, inbox, life);
        if (r.writer) {
            r.write_composed(r.frames_written - 1);   // a last frame whose check never came is not written
            r.writer->finish();
        }
        if (r.view) r.view->finish();
        write_contact_sheet(r, scene, opt.out_dir);
        life.done(r.last_seq, r.frames_written > 0 ? afm::frame_utime(scene, r.frames_written - 1) : 0);
        return static_cast<int>(afm::kExitOk);
    });
}
