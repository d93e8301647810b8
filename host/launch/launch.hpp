// Launch: how afm_launch runs one scene (main.cpp calls its steps in
// order). Validates the scene before starting anything, checks that it sits
// in a private network namespace whose loopback carries the multicast route
// (./afm run puts it there), records the whole bus itself
// (bus_recorder.hpp), starts the run's processes (processes.hpp's table:
// the four, and with --view-fd the page's bridge, afm_view_bridge, with the
// run's key) and supervises them (supervisor.hpp), prints progress
// (progress.hpp), stops everything at the end (or when one dies), and
// writes DIR/run.json (run_record.hpp) and the summary (summary.hpp). The
// command line is options.hpp's; the run's folder and its lock run_folder.hpp's.
#pragma once

#include <lcm/lcm-cpp.hpp>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "bus.hpp"
#include "bus_recorder.hpp"
#include "bus_tap.hpp"
#include "hosts.hpp"
#include "inbox.hpp"
#include "lifecycle.hpp"
#include "options.hpp"
#include "placement.hpp"
#include "progress.hpp"
#include "run_folder.hpp"
#include "run_record.hpp"
#include "scene.hpp"
#include "senders.hpp"
#include "supervisor.hpp"

namespace afm::launch {

// One run: the steps of main, in order, sharing the run's state. Each
// returns -1 to go on, or the exit code (said on stderr).
class Launch {
public:
    explicit Launch(Options o);
    ~Launch();
    Launch(const Launch &) = delete;
    Launch &operator=(const Launch &) = delete;

    int check_out() const { return folder_.check(); }   // --check with --out: may a run take the folder
    int check_scene();   // 1. the scene and the card's acceptance, before anything starts
    int prepare();       // 2. the bus on this namespace's loopback; 3. the run's folder, the tap
    int start();         // 4. the record first, then the processes
    void supervise();    // 5. until every process is done, or one fails or stalls
    void stop();         // 6. everyone stopped; the record last
    int finish();        // 7. run.json, the summary; the exit code

private:
    int take_folder();
    int open_tap();
    void wait_for_spy(int sockets_before);
    void place();
    bool supervise_step(bool *started);
    void start_run();
    void drain();
    nlohmann::json launcher_json() const;
    nlohmann::json view_bridge_json() const;
    nlohmann::json placement_json() const;
    RunParts parts() const;
    int pump(int timeout_ms);
    bool record(bool bus_quiet);
    double wall_s() const;
    const char *bus_url() const;
    std::string stalled_process() const;

    Options o_;
    RunFolder folder_;
    Hosts hosts_;
    afm::Scene scene_;
    int key_fd_ = -1;   // the run's bus key in a memfd, for the children (bus_key.hpp); -1: AFM_BUS_MAC=off
    std::string out_, scene_abs_, scene_run_;
    std::string scene_hash_;   // afm::scene_hash of scene_run_'s text
    std::unique_ptr<lcm::LCM> lc_;
    std::unique_ptr<afm::Inbox> inbox_;
    std::unique_ptr<afm::Lifecycle> life_;   // its heartbeat: starting, running, stop
    Progress prog_;
    std::chrono::steady_clock::time_point wall0_;
    std::unique_ptr<afm::BusTap> tap_;        // the whole bus, without liblcm's receive thread
    std::unique_ptr<afm::Senders> senders_;   // the tap's admitter: the run's own processes on their channels
    long long log_window_ = 0;                // the simulator's window on the record, blocks (0: none)
    std::unique_ptr<afm::BusRecorder> recorder_;
    std::string record_error_;     // a write into the record that failed inside pump()
    int64_t recorded_events_ = 0;  // what the record held when it was closed
    afm::Placement placement_;     // the lockstep's CPU and the observers' (place())
    Supervisor sup_;
    std::string failure_;
    bool finished_ = false;
    int interrupted_ = 0;   // the signal that stopped the run (0: none)
    double wall_ = 0;
    // the CPU readings when the run started and when the simulator's loop
    // was over: what the loop cost each (run.json timing.loop_cpu_us_per_block)
    std::vector<CpuReading> loop_cpu_;
    int64_t messages_ = 0;
};

}  // namespace afm::launch
