// The run record: the one owner of DIR/run.json and its schema. assemble()
// puts it together from the parts' results (the launcher's own, the
// processes' reports in the run's folder, the bus log's counts), judges it
// (verdict.hpp) and checks the log's completeness; write_record() writes it
// whole or not at all (beside, then renamed over). docs/design.md's table of
// keys is held to a run's keys by tests/e2e/test_contract.py and to an
// assembled record by tests/host/test_launch_run_record.cpp.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "children.hpp"

namespace afm {
struct Scene;
}

namespace afm::launch {

// run.json's layout. 2: schema_version, provenance, scene_hash. 3:
// card_sources (where each of the card's constants came from).
constexpr int kRunSchemaVersion = 3;

// The files a run writes in its folder (those an earlier run left there are replaced).
const std::vector<std::string> &run_outputs();

// The distinct blocks of the card's two per-block inputs in a log (their
// seq, through the bus's own decode-and-check): a block the replay can step
// needs both.
struct RecordedBlocks {
    std::set<int64_t> analog, pose;
};

// Message counts per channel in an LCM log, and the blocks recorded; err
// set when the log does not read to its end.
std::map<std::string, int64_t> count_channels(const std::string &path, std::string *err, RecordedBlocks *seqs);

// A process's CPU (s) with its descendants, and theirs apart (-1: none
// alive), by name (the launcher as "afm_launch"), at one moment.
struct LoopCpu {
    double total = -1, children = -1;
};
using CpuReading = std::map<std::string, LoopCpu>;

// What the record is made of besides the files in the run's folder.
struct RunParts {
    std::string out;          // the run's folder, absolute
    std::string scene_abs;    // the scene file's absolute path
    std::string scene_hash;   // of the scene text the run kept
    const Scene *scene = nullptr;
    std::string failure;      // "" when nothing failed
    int interrupted = 0;      // the signal that stopped the run (0: none)
    std::string netns;        // AFM_NETNS_MODE, or "unknown"
    std::string bus_url;
    double sim_seconds = 0;   // reached (the simulator's last heartbeat)
    double wall_seconds = 0;  // the whole run
    nlohmann::json processes = nlohmann::json::array();   // process_json() of each, with its "host"
    nlohmann::json hosts, launcher, placement, provenance;
    // the CPU readings at the loop's start and end (loop_cpu_us_per_block);
    // fewer than two: none
    std::vector<CpuReading> loop_cpu;
};

// run.json's entry for a child (name, exit code, log, CPUs, the kernel's accounting).
nlohmann::json process_json(const Child &c);

// What made this build (provenance.json, cmake/provenance.cmake); null where it cannot be read.
nlohmann::json provenance(const std::string &path);

// The record; messages (if given): the bus messages the log holds.
nlohmann::json assemble(const RunParts &p, int64_t *messages = nullptr);

// run.json in `out`, whole or not at all; "" or why not (one line naming the file).
std::string write_record(const std::string &out, const nlohmann::json &run);

}  // namespace afm::launch
