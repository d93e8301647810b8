// fw_node: the A/D card's firmware on the bus. A thin adapter: it hands the
// card's input messages to CardNode (card_node.hpp: the card, fw_card.h,
// behind unit conversion) and publishes what it answers, in order: what the
// lockstep waits for at once, the observers' channels aside (bus/aside.hpp:
// from a thread of its own, in batches). The protocol and
// everything the card computes are described in card_node.hpp.
#include <lcm/lcm-cpp.hpp>

#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "afm/heartbeat_t.hpp"
#include "aside.hpp"
#include "bus.hpp"
#include "card_node.hpp"
#include "inbox.hpp"
#include "process.hpp"
#include "run_process.hpp"
#include "scene.hpp"

static_assert(FW_FLAG_SAT_SN == afm::fw_state_t::FLAG_SAT_SN, "flag bits must match the firmware");
static_assert(FW_FLAG_SAT_SL == afm::fw_state_t::FLAG_SAT_SL, "flag bits must match the firmware");
static_assert(FW_FLAG_FX_UNOBSERVABLE == afm::fw_state_t::FLAG_FX_UNOBSERVABLE, "flag bits must match the firmware");
static_assert(FW_FLAG_VIRTUAL_SN == afm::fw_state_t::FLAG_VIRTUAL_SN, "flag bits must match the firmware");
static_assert(FW_FLAG_SAT_FORCE == afm::fw_state_t::FLAG_SAT_FORCE, "flag bits must match the firmware");
static_assert(FW_FLAG_CONTACT == afm::fw_state_t::FLAG_CONTACT, "flag bits must match the firmware");
static_assert(FW_FLAG_THETA_UNKNOWN == afm::fw_state_t::FLAG_THETA_UNKNOWN, "flag bits must match the firmware");
static_assert(FW_FLAG_SAT_POS == afm::fw_state_t::FLAG_SAT_POS, "flag bits must match the firmware");
static_assert(FW_FLAG_SQUEEZE == afm::fw_state_t::FLAG_SQUEEZE, "flag bits must match the firmware");
static_assert(FW_FLAG_INTERLOCK == afm::fw_state_t::FLAG_INTERLOCK, "flag bits must match the firmware");
static_assert(FW_FLAG_RIDEOVER == afm::fw_state_t::FLAG_RIDEOVER, "flag bits must match the firmware");
static_assert(FW_FLAG_BLIND_PUSH == afm::fw_state_t::FLAG_BLIND_PUSH, "flag bits must match the firmware");

namespace {

// fw_node's command line and its one check of each option (command_line.hpp).
struct Options {
    std::string scene_path, out_dir;
    int64_t crash_at = -1;
    std::vector<int> aside_cpus;
    afm::CardBackendOptions where;
};

constexpr const char *kOptions = "options:";

const afm::Process<Options> kProcess = {
    {"fw_node",
    "usage: fw_node --scene FILE [options]\n"
    "  The firmware on the bus; normally started by ./afm run inside the run's namespace.\n",
    {
        {{"--scene", "FILE", nullptr, nullptr, true}, afm::cli::text(&Options::scene_path)},
        {{"--out", "DIR", kOptions, "write DIR/fw_report.json at the end (what the node\nrefused, by reason)"},
         afm::cli::text(&Options::out_dir)},
        {{"--firmware", "host|qemu", kOptions,
          "where the card runs: linked into this process (host, the default), or\n"
          "built for its processor on an emulated mps2-an386 board\n"
          "(qemu-system-arm -icount shift=0; docs/pil.md); its output\n"
          "in DIR/logs/board.log"},
         [](const std::string &v, Options *o) { return afm::read_firmware(v, &o->where.firmware); }},
        {{"--board-elf", "ELF", kOptions, "the board's image (default: the build's afm_board.elf)"},
         [](const std::string &v, Options *o) { return afm::cli::read_text(v, &o->where.board_elf); }},
        {{"--crash-at-block", "N", kOptions, "failure injection: exit with code 70 on receiving block N (-1: never)"},
         afm::cli::whole(&Options::crash_at, -1, std::numeric_limits<long long>::max(), "a block number")},
        {{"--aside-cpus", "LIST", kOptions,
          "the CPUs (\"0-1\") the thread that publishes the observers' channels\n"
          "aside may use (bus/aside.hpp; the launcher passes every CPU of the run)"},
         afm::cli::cpus(&Options::aside_cpus)},
    }},
    {AFM_CH_AFM_ANALOG, AFM_CH_HOST_OBJECT_FIX, AFM_CH_HAPTIC_POSE, AFM_CH_AFM_HEARTBEAT},
    {AFM_CH_AFM_CMD, AFM_CH_FW_STATE, AFM_CH_HAPTIC_FORCE},
    [](const Options &o) { return o.out_dir.empty() ? std::string() : o.out_dir + "/fw_report.json"; }};

constexpr int kCrashExitCode = 70;

struct Node {
    const afm::Scene &scene;
    lcm::LCM &lc;
    afm::Aside &aside;
    afm::CardNode card;
    afm::Lifecycle &life;
    int64_t crash_at = -1;
    bool sim_done = false;

    Node(const afm::Scene &s, afm::Lifecycle &li, afm::Aside &a, const afm::CardBackendOptions &where)
        : scene(s), lc(li.bus()), aside(a), card(s, where), life(li) {}

    // In the card's order; a channel no process of the lockstep reads aside.
    void publish(const afm::Outbox &box)
    {
        for (const auto &o : box) {
            if (afm::lockstep_reads(scene, o.channel)) afm::publish_raw(lc, o.channel, o.data.data(), o.data.size());
            else aside.post(o.channel, o.data.data(), o.data.size());
        }
    }

    afm::Reject on_analog(const afm::analog_block_t &b)
    {
        if (b.seq == crash_at) {
            std::fprintf(stderr, "fw_node: failure injection: crashing at block %lld\n", (long long)b.seq);
            std::exit(kCrashExitCode);
        }
        afm::Reject why;
        publish(card.on_analog(b, &why));
        life.running(card.done(), card.sim_utime_done());
        return why;
    }

    afm::Reject on_pose(const afm::haptic_pose_t &p)
    {
        afm::Reject why;
        publish(card.on_pose(p, &why));
        return why;
    }

    afm::Reject on_fix(const afm::object_fix_t &m)
    {
        std::string note;
        afm::Reject why;
        publish(card.on_fix(m, &note, &why));
        if (!note.empty()) std::fprintf(stderr, "fw_node: %s\n", note.c_str());
        return why;
    }

    afm::Reject on_heartbeat(const afm::heartbeat_t &m)
    {
        if (afm::run_over(m)) sim_done = true;
        return afm::Reject::none;
    }
};

}  // namespace

// fw_report.json: the card's account of the run (the force interlock's
// trips: fw_guard.h; null when the scene turns it off).
static nlohmann::json card_report(Node &node, const afm::Inbox &inbox, const afm::Aside &aside)
{
    const fw_models_t &m = node.card.backend().models();
    return {{"blocks_stepped", node.card.done() + 1}, {"rejected", inbox.report()},
            {"aside", aside.report()},
            {"interlock_trips", m.interlock ? nlohmann::json(m.interlock_trips) : nlohmann::json(nullptr)},
            {"unobservable_push_blocks", node.card.tally().unobservable_push_blocks},
            {"saturated_samples", node.card.tally().saturated_samples},
            {"board", node.card.backend().report()}};
}

int main(int argc, char **argv)
{
    return afm::run_process(kProcess, argc, argv, [](const Options &opt, afm::Lifecycle &life) {
        afm::CardBackendOptions where = opt.where;
        if (!opt.out_dir.empty() && where.firmware == "qemu") where.board_log = opt.out_dir + "/logs/board.log";
        const afm::Scene scene = afm::load_scene(opt.scene_path);
        lcm::LCM &lc = life.bus();
        afm::Aside aside(opt.aside_cpus);
        Node node(scene, life, aside, where);
        node.crash_at = opt.crash_at;
        afm::Inbox inbox(&lc);
        inbox.on<afm::analog_block_t>(AFM_CH_AFM_ANALOG, [&](const afm::analog_block_t &m) { return node.on_analog(m); });
        inbox.on<afm::object_fix_t>(AFM_CH_HOST_OBJECT_FIX, [&](const afm::object_fix_t &m) { return node.on_fix(m); });
        inbox.on<afm::haptic_pose_t>(AFM_CH_HAPTIC_POSE, [&](const afm::haptic_pose_t &m) { return node.on_pose(m); });
        inbox.on<afm::heartbeat_t>(AFM_CH_AFM_HEARTBEAT, [&](const afm::heartbeat_t &m) { return node.on_heartbeat(m); });
        afm::check_lockstep_reads(scene, inbox.channels(), "fw_node");
        life.check_subscriptions(inbox.channels());
        const auto report = life.report_from([&] { return card_report(node, inbox, aside); });
        life.serve(
            [&] {
                const int64_t done = node.card.done();
                if (done < 0) node.card.check_alive();   // a board that died before the first block is named at once (a block's exchange names it after)
                return afm::Progress{done >= 0, done, node.card.sim_utime_done()};
            },
            [&](int ms) { inbox.handle(ms); }, [&] { return node.sim_done; });
        aside.flush();   // the record holds every block before "done"
        life.done(node.card.done(), node.card.sim_utime_done());
        return afm::kExitOk;
    });
}
