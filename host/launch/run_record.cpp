#include "run_record.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "afm/analog_block_t.hpp"
#include "afm/haptic_pose_t.hpp"
extern "C" {
#include "fw_guard.h"
}
#include "bus.hpp"
#include "bus_recorder.hpp"
#include "card_setup.hpp"
#include "card_table.hpp"
#include "lcmlog.hpp"
#include "processes.hpp"
#include "scene.hpp"
#include "verdict.hpp"

namespace afm::launch {

namespace fs = std::filesystem;
using nlohmann::json;

const std::vector<std::string> &run_outputs()
{
    static const std::vector<std::string> files = {
        "frames", "logs", "bus.lcmlog", "run.json", "scene.yaml", "video.mp4", "video.avi", "sim_report.json", "renderer_report.json",
        "operator_report.json", "fw_report.json", "scan_initial.png", "contact_sheet.png", "scan_initial.gsf", "scan_final.gsf",
        "display_final.gsf", "fidelity.json", "fidelity_diff.png", kViewBridgeReport};
    return files;
}

std::map<std::string, int64_t> count_channels(const std::string &path, std::string *err, RecordedBlocks *seqs)
{
    std::map<std::string, int64_t> counts;
    try {
        afm::LogReader log(path);
        afm::LogEvent ev;
        while (log.read(&ev)) {
            ++counts[ev.channel];
            afm::analog_block_t b;
            afm::haptic_pose_t p;
            if (ev.channel == AFM_CH_AFM_ANALOG && afm::decode_checked(ev.data.data(), ev.data.size(), &b) == afm::Reject::none)
                seqs->analog.insert(b.seq);
            if (ev.channel == AFM_CH_HAPTIC_POSE && afm::decode_checked(ev.data.data(), ev.data.size(), &p) == afm::Reject::none)
                seqs->pose.insert(p.seq);
        }
    } catch (const afm::LogError &e) {
        *err = e.what();
    }
    return counts;
}

json process_json(const Child &c)
{
    return {{"name", c.name}, {"exit_code", c.exit_code}, {"log", "logs/" + c.name + ".log"}, {"cpus", c.cpus},
            {"cpu_user_s", c.cpu_user_s}, {"cpu_system_s", c.cpu_system_s}, {"max_rss_kb", c.max_rss_kb}};
}

json provenance(const std::string &path)
{
    std::ifstream f(path);
    if (!f) return nullptr;
    const auto j = json::parse(f, nullptr, false);
    return j.is_discarded() ? json(nullptr) : j;
}

namespace {

// What the card ran with, in the firmware's units (fw_card_init on the
// scene's configuration, as fw_node has it): the displacement constants
// in use, the chain, the ADC.
json card_json(const Scene &scene)
{
    const afm::CardSetup setup(scene);
    fw_card_t card;
    if (fw_card_init(&card, &setup.config(), &setup.storage(), nullptr) != FW_OK) return nullptr;
    const fw_board_config_t &b = setup.config().board;
    return {{"adc_bits", b.adc_bits},
            {"word_bits", setup.config().word_bits == 0 ? 32 : setup.config().word_bits},
            {"normal_gain_pn_per_v", b.normal_gain_pn_per_v},
            {"lateral_gain_pn_per_v", b.lateral_gain_pn_per_v},
            {"deflection_pm_per_v", b.deflection_pm_per_v},
            {"disp_n_pm_per_v", fw_card_disp_n_pm_per_v(&card)},
            {"disp_l_pm_per_v", fw_card_disp_l_pm_per_v(&card)},
            {"scan_angle_mdeg", b.scan_angle_mdeg},
            {"mu_ppm", b.mu_ppm},
            {"adhesion_pn", b.adhesion_pn},
            {"wire_friction_pn_per_um", setup.config().wire_friction_pn_per_um},
            {"wire_mu_ppm", setup.config().wire_mu_ppm},
            {"twist_urad_per_v", static_cast<double>(card.twist_rad_per_v) * 1e6 / static_cast<double>(1 << 30)},
            {"samples_per_block", scene.samples_per_block()},
            {"full_scale_pn", fw_guard_full_scale_pn(b.normal_gain_pn_per_v)}};
}

// Where each of the card's constants came from (card_table.hpp: the
// scene's card section, a bench calibration, a nominal, the run's settings).
json card_sources_json(const Scene &scene)
{
    json out = json::array();
    for (const auto &c : afm::card_sources(scene))
        out.push_back({{"field", c.field}, {"key", c.key}, {"value", c.value}, {"source", c.source}});
    return out;
}

// CPU a block in the loop, per process (from the run's start, within the
// launcher's 5 ms checks, to the simulator's heartbeat for its last block,
// within a batch of the record: about the loop), with its descendants, and
// of that "NAME (its children)": QEMU under fw_node, ffmpeg under the
// renderer; afm_launch is the record and the heartbeats. A figure is given
// only where both readings are whole: a process whose descendants were
// fewer, or had used less, at the end (one ending between the readings)
// gets none, rather than a short one.
json loop_cpu_json(const std::vector<CpuReading> &r, int64_t blocks)
{
    json cpu = json::object();
    const auto per_block = [&](double a, double b) { return (b - a) / static_cast<double>(blocks) * 1e6; };
    for (const auto &[name, end] : r[1]) {
        const auto it = r[0].find(name);
        if (it == r[0].end()) continue;
        const LoopCpu &start = it->second;
        if (start.total < 0 || end.total < start.total) continue;
        if (start.children >= 0 && end.children < start.children) continue;
        cpu[name] = per_block(start.total, end.total);
        if (start.children >= 0) cpu[name + " (its children)"] = per_block(start.children, end.children);
    }
    return cpu;
}

// The run's speed "as a run is made" (docs/design.md, run.json timing):
// the loop, from the simulator's first block to the card's answer to its
// last (sim_report.json loop_wall_seconds, the one owner of that figure:
// scans served and waits for frames and the record included), against the
// blocks' simulated time; beside it the whole run, the launcher's start to
// the end of the run (wall_seconds). Null figures when the simulator wrote
// no report.
json timing_json(const RunParts &p, const json &run)
{
    const double wall = p.wall_seconds;
    json t = {{"whole_seconds", wall}, {"whole_realtime_factor", run["sim_seconds_per_wall_second"]}};
    const bool have = run.contains("sim") && run["sim"].is_object() && run["sim"].contains("loop_wall_seconds") && run["sim"].contains("blocks");
    const double loop_s = have ? run["sim"]["loop_wall_seconds"].get<double>() : 0.0;
    const int64_t blocks = have ? run["sim"]["blocks"].get<int64_t>() : 0;
    const double loop_sim_s = static_cast<double>(blocks) / p.scene->block_hz;
    const bool ok = have && loop_s > 0 && blocks > 0;
    t["loop_seconds"] = ok ? json(loop_s) : json(nullptr);
    t["loop_blocks"] = blocks;
    t["loop_simulated_seconds"] = loop_sim_s;
    t["loop_us_per_block"] = ok ? json(loop_s / static_cast<double>(blocks) * 1e6) : json(nullptr);
    t["loop_realtime_factor"] = ok ? json(loop_sim_s / loop_s) : json(nullptr);
    t["outside_loop_seconds"] = ok ? json(wall - loop_s) : json(nullptr);
    t["loop_cpu_us_per_block"] = ok && p.loop_cpu.size() == 2 ? loop_cpu_json(p.loop_cpu, blocks) : json(nullptr);
    return t;
}

// Each process's own report, under its name.
void merge_reports(const std::string &out, json *run)
{
    for (const std::string rep : {"sim_report.json", "renderer_report.json", "operator_report.json", "fw_report.json", "fidelity.json"}) {
        std::ifstream f(out + "/" + rep);
        if (!f) continue;
        json j = json::parse(f, nullptr, false);
        if (j.is_discarded()) {
            (*run)["report_errors"].push_back(rep + ": not valid JSON");
            continue;
        }
        const std::string key = rep.substr(0, rep.find_first_of("_."));
        if (key == "sim" && j.contains("effects")) (*run)["effects"] = j["effects"];
        (*run)[key] = j;
    }
}

// Completeness of the record: distinct analog blocks and poses in the log
// against the blocks the simulator simulated (a recorder starved of CPU
// can lose datagrams; a block missing either input cannot be replayed).
void log_completeness(const RecordedBlocks &recorded, json *run)
{
    // a simulator that did not finish its part (its report's "ended": run_process.hpp) counts no blocks to hold
    if (!run->contains("sim") || !(*run)["sim"].contains("blocks") || (*run)["sim"].value("ended", "done") != "done") return;
    const int64_t sent = (*run)["sim"]["blocks"].get<int64_t>();
    // a block the simulator sent (a datagram with another seq is not one)
    auto in_run = [&](const std::set<int64_t> &s) {
        return static_cast<int64_t>(std::count_if(s.begin(), s.end(), [&](int64_t q) { return q >= 0 && q < sent; }));
    };
    const int64_t analog_seqs = in_run(recorded.analog), pose_seqs = in_run(recorded.pose);
    const bool complete = analog_seqs == sent && pose_seqs == sent;
    (*run)["log"] = {{"analog_blocks_recorded", analog_seqs},
                     {"pose_blocks_recorded", pose_seqs},
                     {"analog_blocks_simulated", sent},
                     {"complete", complete}};
    if (!complete)
        std::fprintf(stderr, "run: warning: the bus log holds %lld analog blocks and %lld poses of %lld blocks (the recorder was starved of CPU)\n",
                     static_cast<long long>(analog_seqs), static_cast<long long>(pose_seqs), static_cast<long long>(sent));
}

// The files the run wrote, by name.
json outputs(const std::string &out)
{
    json outs = {"bus.lcmlog", "run.json", "scene.yaml", "frames/"};
    for (const char *v : {"video.mp4", "video.avi", "contact_sheet.png", "scan_initial.png", "scan_initial.gsf", "scan_final.gsf",
                          "display_final.gsf", "fidelity.json", "fidelity_diff.png"})
        if (fs::exists(out + "/" + v)) outs.push_back(v);
    for (const auto &e : fs::directory_iterator(out))
        if (e.path().filename().string().rfind("scan_local_", 0) == 0) outs.push_back(e.path().filename().string());
    return outs;
}

// What ran and how it went, before the processes' reports.
json head(const RunParts &p)
{
    json run;
    run["schema_version"] = kRunSchemaVersion;
    run["provenance"] = p.provenance;
    run["scene"] = p.scene_abs;
    run["scene_hash"] = p.scene_hash;
    run["scene_name"] = p.scene->name;
    run["seed"] = p.scene->seed;
    run["status"] = p.interrupted ? "interrupted" : p.failure.empty() ? "ok" : "failed";
    if (!p.failure.empty()) run["error"] = p.failure;
    run["netns"] = p.netns;
    run["bus_url"] = p.bus_url;
    run["time_mode"] = p.scene->time_mode;
    run["sim_seconds"] = p.sim_seconds;
    run["wall_seconds"] = p.wall_seconds;
    run["sim_seconds_per_wall_second"] = p.wall_seconds > 0 ? p.sim_seconds / p.wall_seconds : 0.0;
    run["samples"] = std::llround(p.sim_seconds * p.scene->sample_rate_hz);
    int frames = 0;
    for (const auto &e : fs::directory_iterator(p.out + "/frames"))
        if (e.path().extension() == ".png") ++frames;
    run["frames"] = frames;
    run["frames_expected"] = p.scene->total_frames();   // fewer when the planner finished early (the renderer's report)
    run["processes"] = p.processes;
    run["hosts"] = p.hosts;
    return run;
}

}  // namespace

json assemble(const RunParts &p, int64_t *messages)
{
    const std::string log = p.out + "/bus.lcmlog";
    std::string log_err;
    RecordedBlocks recorded;
    const auto counts = count_channels(log, &log_err, &recorded);
    if (messages)
        for (const auto &kv : counts) *messages += kv.second;
    json run = head(p);
    run["log_bytes"] = fs::exists(log) ? static_cast<int64_t>(fs::file_size(log)) : 0;
    run["channels"] = afm::channels_json(counts);
    if (!log_err.empty()) run["log_error"] = log_err;
    run["card"] = card_json(*p.scene);
    run["card_sources"] = card_sources_json(*p.scene);
    run["launcher"] = p.launcher;
    run["placement"] = p.placement;
    merge_reports(p.out, &run);
    run["timing"] = timing_json(p, run);
    if (run.contains("fw") && run["fw"].contains("board")) run["card"]["board"] = run["fw"]["board"];   // where the card ran
    if (run.contains("renderer") && run["renderer"].contains("frames_expected")) run["frames_expected"] = run["renderer"]["frames_expected"];
    run["verdict"] = afm::judge(run, p.scene->expect);   // the run's own checks (verdict.hpp)
    log_completeness(recorded, &run);
    run["outputs"] = outputs(p.out);
    return run;
}

std::string write_record(const std::string &out, const json &run)
{
    const std::string path = out + "/run.json", tmp = path + ".partial";
    {
        std::ofstream f(tmp);
        f << run.dump(2) << "\n";
        f.flush();
        if (!f) {
            const int err = errno ? errno : EIO;
            std::error_code ec;
            fs::remove(tmp, ec);
            return "cannot write " + path + ": " + std::strerror(err) + " (status would have been '" + run.value("status", "?") + "'" +
                   (run.contains("error") ? ": " + run["error"].get<std::string>() : "") + ")";
        }
    }
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec) {
        fs::remove(tmp, ec);
        return "cannot write " + path + ": " + ec.message();
    }
    return "";
}

}  // namespace afm::launch
