// afm_replay: replays a recorded run through the card as built now and
// compares its answers with the recording (./afm replay RUN_DIR).
//
// The card is a pure function of its inputs (fw_card.h). Replay reads the
// run's bus.lcmlog and feeds what the card consumed, AFM_ANALOG,
// HAPTIC_POSE and HOST_OBJECT_FIX, in the order they were recorded, to a
// CardNode (the adapter fw_node runs, card_node.hpp): no simulator, no
// bus. Every output, AFM_CMD, HAPTIC_FORCE and FW_STATE, is
// compared with the recorded one of the same block (and
// fix): identical bit for bit, or the first divergence is named (block,
// channel, field, recorded and new value) with a count and the worst
// difference per channel. Replay is open loop: the recorded signals are fed
// as recorded, so past a divergence the outputs show what the new firmware
// computes from the old run's signals, not what a new run would do.
#include "help_replay.h"
#include <lcm/eventlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string_view>
#include <unordered_map>
#include <set>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include <nlohmann/json.hpp>

#include "afm/heartbeat_t.hpp"
#include "afm_channels.h"
#include "card_node.hpp"
#include "command_line.hpp"
#include "inbox.hpp"
#include "lcmlog.hpp"
#include "replay_fields.hpp"
#include "scene.hpp"

namespace fs = std::filesystem;
using namespace afm::replay;

namespace {

// The replay's command line (kCommandLine below: each option's one check),
// and what locate() finds from RUN_DIR.
struct Options {
    std::string run;   // RUN_DIR
    std::string log, scene, write;
    afm::CardBackendOptions where;   // --firmware, --board-elf
    bool quiet = false;
    double run_wall_s = 0;
    bool log_complete = true;
};


// RUN_DIR (or its log) -> the log, the scene, and what run.json says.
bool locate(const std::string &arg, Options *o, std::string *err)
{
    fs::path dir = arg;
    if (fs::is_regular_file(arg)) {
        o->log = arg;
        dir = fs::path(arg).parent_path();
    } else if (fs::is_directory(arg)) {
        o->log = (dir / "bus.lcmlog").string();
        if (!fs::exists(o->log)) {
            *err = arg + ": no bus.lcmlog in this folder (is it a run folder?)";
            return false;
        }
    } else {
        *err = arg + ": no such run folder or log file";
        return false;
    }
    std::ifstream rj(dir / "run.json");
    if (rj) {
        const auto j = nlohmann::json::parse(rj, nullptr, false);
        if (!j.is_discarded()) {
            o->run_wall_s = j.value("wall_seconds", 0.0);
            if (j.contains("log") && j["log"].is_object()) o->log_complete = j["log"].value("complete", true);
            if (o->scene.empty() && !fs::exists(dir / "scene.yaml") && j.contains("scene") && j["scene"].is_string())
                o->scene = j["scene"].get<std::string>();
        }
    }
    if (o->scene.empty()) o->scene = (dir / "scene.yaml").string();
    if (!fs::exists(o->scene)) {
        *err = o->scene + ": the run's scene is not there (give it with --scene FILE)";
        return false;
    }
    return true;
}

// The new log of --write (none: no path).
struct EventLogWriter {
    std::unique_ptr<afm::LogWriter> log;
    explicit EventLogWriter(const std::string &path)
    {
        if (!path.empty()) log = std::make_unique<afm::LogWriter>(path);
    }
    void write(int64_t utime, const std::string &ch, const std::vector<uint8_t> &d)
    {
        if (log) log->write(utime, ch, d.data(), d.size());
    }
};

// The recorded and the replayed outputs, keyed by (block, channel, fix).
struct Outputs {
    std::map<Key, std::vector<uint8_t>> recorded, replayed;
    std::vector<std::string> notes;     // what the card said about fixes
    int64_t events = 0, inputs = 0;
    int64_t refused_inputs = 0;         // input datagrams the card's inbox refused (inbox.hpp), as fw_node did
    int64_t held_back = 0;              // inputs recorded one block early, held until the card could take them
    std::vector<std::string> refused_at;   // the first few of them, by byte offset in the log
    int64_t foreign_outputs = 0;        // datagrams on an output channel that are not the card's (do not decode, or name a block it never stepped)
    int64_t self_inconsistent = 0;      // recorded repeats that differ from their first copy
    std::set<Key> inconsistent;         // their keys: the recording answers those blocks twice, differently
    int64_t before_fw_state = 0;        // recorded messages on FW_FORCE, FW_TIP and FW_OBJECTS (kBeforeFwState)
    bool predates_fw_state = false;     // a recording of an earlier bus: no FW_STATE of this build's type, and messages on those
    nlohmann::json board;               // where the card ran, and on the board its cost (card_backend.hpp)
};

// Hashes an output on its length and at most 64 bytes at either end: equal
// hashes are then compared whole.
struct EndsHash {
    std::size_t operator()(std::string_view v) const
    {
        const std::size_t n = std::min<std::size_t>(v.size(), 64);
        return std::hash<std::string_view>()(v.substr(0, n)) ^ (std::hash<std::string_view>()(v.substr(v.size() - n)) * 31u) ^
               v.size();
    }
};

std::string_view bytes_of(const std::vector<uint8_t> &d) { return {reinterpret_cast<const char *>(d.data()), d.size()}; }

// A recorded output, as read (keyed once the whole log is read).
struct RecordedRaw {
    std::string channel;
    std::vector<uint8_t> data;
    uint64_t offset;
};

// Feeding: the card's inputs through the same decode-and-check as fw_node's
// (inbox.hpp), so that a datagram the node refused in the run is refused
// here; the card's outputs kept by key, and indexed by content.
//
// An input one block beyond what the card can take now is held until it
// can: the card had it in time in the run, but the recorder's socket may
// have got it after a later datagram of another sender (two senders'
// deliveries to the bus's sockets interleave differently on two cores).
// The card steps a block once it has both inputs, in either order, so the
// order it got them in does not change its answers.
class Feeder {
public:
    Feeder(const afm::Scene &scene, const afm::CardBackendOptions &where, const std::string &write_path, Outputs *r)
        : node_(scene, where), out_(write_path), r_(r), inbox_(nullptr)
    {
        inbox_.on<afm::analog_block_t>(AFM_CH_AFM_ANALOG, [this](const afm::analog_block_t &b) {
            if (!early(b.seq)) return analog(b);
            held_analog_.emplace(b.seq, b);
            return afm::Reject::none;
        });
        inbox_.on<afm::haptic_pose_t>(AFM_CH_HAPTIC_POSE, [this](const afm::haptic_pose_t &p) {
            if (!early(p.seq)) return pose(p);
            held_pose_.emplace(p.seq, p);
            return afm::Reject::none;
        });
        inbox_.on<afm::object_fix_t>(AFM_CH_HOST_OBJECT_FIX, [this](const afm::object_fix_t &f) {
            std::string note;
            afm::Reject why;
            take(node_.on_fix(f, &note, &why), ev_utime_);
            if (!note.empty()) r_->notes.push_back(note);
            return why;
        });
    }

    static bool is_input(const std::string &ch)
    {
        return ch == AFM_CH_AFM_ANALOG || ch == AFM_CH_HAPTIC_POSE || ch == AFM_CH_HOST_OBJECT_FIX;
    }

    // One recorded input, given to the card (or held, or refused and named).
    void input(const afm::LogEvent &ev)
    {
        out_.write(ev.utime, ev.channel, ev.data);
        ev_utime_ = ev.utime;
        const afm::Reject why = inbox_.deliver(ev.channel, ev.data.data(), ev.data.size());
        release_held();
        if (why == afm::Reject::none) ++r_->inputs;
        else if (r_->refused_at.size() < 5)
            r_->refused_at.push_back("byte offset " + std::to_string(ev.offset) + ": " + ev.channel + " message refused (" +
                                     afm::reject_name(why) + ")");
    }

    // The log is read: inputs held to the end (the card never reached their
    // block) are refused as from the future, as the card refused them in the run.
    void finish()
    {
        for (const auto &[seq, b] : held_analog_) inbox_.count(analog(b), AFM_CH_AFM_ANALOG);
        for (const auto &[seq, p] : held_pose_) inbox_.count(pose(p), AFM_CH_HAPTIC_POSE);
        r_->refused_inputs = inbox_.rejected().total();
    }

    // The key of a replayed output with these bytes on this channel, if any.
    bool key_by_content(const std::vector<uint8_t> &data, int rank, Key *k) const
    {
        for (auto [it, end] = by_content_.equal_range(bytes_of(data)); it != end; ++it)
            if (std::get<1>(it->second) == rank) {
                *k = it->second;
                return true;
            }
        return false;
    }

    int64_t max_analog() const { return max_analog_; }           // the last analog block the card took
    nlohmann::json board() const { return node_.backend().report(); }   // where the card ran, its cost
    int64_t done() const { return node_.done(); }                 // the last block the card stepped
    bool analog_seen(int64_t seq) const { return analog_seen_.count(seq) > 0; }

private:
    void take(const afm::Outbox &box, int64_t utime)
    {
        for (const auto &m : box) {
            const Key k{m.seq, output_rank(m.channel), m.fix_id};
            auto [it, fresh] = r_->replayed.try_emplace(k, m.data);
            if (fresh) by_content_.emplace(bytes_of(it->second), k);
            out_.write(utime, m.channel, m.data);
        }
    }
    afm::Reject analog(const afm::analog_block_t &b)
    {
        afm::Reject why;
        take(node_.on_analog(b, &why), ev_utime_);
        if (why == afm::Reject::none) max_analog_ = std::max(max_analog_, b.seq);
        analog_seen_.insert(b.seq);
        return why;
    }
    afm::Reject pose(const afm::haptic_pose_t &p)
    {
        afm::Reject why;
        take(node_.on_pose(p, &why), ev_utime_);
        return why;
    }
    // an input for the block after the next one: held until the card gets there
    bool early(int64_t seq) const { return node_.done() >= 0 && seq == node_.done() + 2; }
    template <class M, class Give> bool release_one(std::map<int64_t, M> &held, Give give)
    {
        if (held.empty() || held.begin()->first > node_.done() + 1) return false;
        give(held.begin()->second);
        held.erase(held.begin());
        ++r_->held_back;
        return true;
    }
    void release_held()
    {
        while (release_one(held_analog_, [this](const afm::analog_block_t &b) { analog(b); }) ||
               release_one(held_pose_, [this](const afm::haptic_pose_t &p) { pose(p); })) {}
    }

    afm::CardNode node_;
    EventLogWriter out_;
    Outputs *r_;
    afm::Inbox inbox_;
    int64_t ev_utime_ = 0;
    int64_t max_analog_ = -1;
    std::set<int64_t> analog_seen_;   // every decodable analog block's seq, taken or refused
    std::map<int64_t, afm::analog_block_t> held_analog_;
    std::map<int64_t, afm::haptic_pose_t> held_pose_;
    // the replay's outputs by content, so that a recorded output equal to
    // one of them needs no decoding to find its key
    std::unordered_multimap<std::string_view, Key, EndsHash> by_content_;
};

// Keying: the recorded outputs' keys, by content where the replay gave the
// same bytes on that channel, else from the message itself; a datagram the
// card never sent (it does not decode, or names a block the card never
// stepped) is foreign.
void key_recorded(std::vector<RecordedRaw> &raws, const Feeder &feed, Outputs *r)
{
    for (auto &raw : raws) {
        Key k{};
        const bool known = feed.key_by_content(raw.data, output_rank(raw.channel), &k);
        try {
            if (!known) k = output_key(raw.channel, raw.data);
        } catch (const DecodeError &) {
            ++r->foreign_outputs;
            continue;
        }
        if (std::get<0>(k) < -1 || std::get<0>(k) > feed.max_analog()) {
            ++r->foreign_outputs;
            continue;
        }
        auto [it, fresh] = r->recorded.try_emplace(k, std::move(raw.data));
        if (!fresh && it->second != raw.data) {
            ++r->self_inconsistent;
            r->inconsistent.insert(k);
        }
    }
    r->predates_fw_state = r->before_fw_state > 0 && std::none_of(r->recorded.begin(), r->recorded.end(), [](const auto &kv) {
                               return std::get<1>(kv.first) == output_rank(AFM_CH_FW_STATE);
                           });
}

// Coverage: every block the log's analog blocks cover must have been
// stepped. An analog block for the block after the card's last one (taken
// and waiting for its pose, or refused as from the future) means the log
// lost, or holds late, an input that fw_node had in time, and nothing after
// it can be judged.
void check_coverage(const std::string &log, const Feeder &feed)
{
    const int64_t next = feed.done() + 1;
    if (!feed.analog_seen(next)) return;
    throw afm::LogError(log + ": the log holds AFM_ANALOG of block " + std::to_string(next) + ", but the card could step only to block " +
                        std::to_string(feed.done()) + ": the recording misses, or holds out of order, an input of block " +
                        std::to_string(next) +
                        " (its HAPTIC_POSE or AFM_ANALOG, or one of the block before; a recorder starved of CPU loses or delays messages)");
}

// Reads the log, feeds the card's inputs to a CardNode as fw_node would,
// keeps both sides' outputs. Throws LogError (file, offset) or SceneError.
Outputs run_replay(const Options &o)
{
    Outputs r;
    const afm::Scene scene = afm::load_scene(o.scene);
    Feeder feed(scene, o.where, o.write, &r);
    std::vector<RecordedRaw> recorded_raw;
    afm::LogReader log(o.log);
    log.only({AFM_CH_AFM_ANALOG, AFM_CH_HAPTIC_POSE, AFM_CH_HOST_OBJECT_FIX, AFM_CH_AFM_CMD, AFM_CH_HAPTIC_FORCE, AFM_CH_FW_STATE,
              kBeforeFwState[0], kBeforeFwState[1], kBeforeFwState[2]});
    afm::LogEvent ev;
    while (log.read(&ev)) {
        if (Feeder::is_input(ev.channel)) feed.input(ev);
        else if (output_rank(ev.channel) < 0) ++r.before_fw_state;
        else recorded_raw.push_back({ev.channel, std::move(ev.data), ev.offset});
    }
    feed.finish();
    r.board = feed.board();
    r.events = log.events();
    key_recorded(recorded_raw, feed, &r);
    check_coverage(o.log, feed);
    return r;
}

// Every key on either side, in block order: the per-channel figures and
// the first divergence.
struct Verdict {
    std::map<std::string, ChannelStats> stats;
    Divergence first;
    int64_t blocks = 0;
    int64_t messages = 0;
    std::vector<std::string> compared;   // the output channels compared (all but FW_STATE in a recording before it)
};

Verdict compare_all(const Outputs &r)
{
    Verdict v;
    std::set<Key> keys;
    for (const auto &kv : r.recorded) keys.insert(kv.first);
    for (const auto &kv : r.replayed) keys.insert(kv.first);
    const bool skip_state = r.predates_fw_state;
    for (const auto &c : kOutputs)
        if (!(c == AFM_CH_FW_STATE && skip_state)) v.compared.push_back(c);
    for (const Key &k : keys) {
        const std::string &ch = kOutputs[static_cast<std::size_t>(std::get<1>(k))];
        const auto rec = r.recorded.find(k), now = r.replayed.find(k);
        if (ch == AFM_CH_FW_STATE && now != r.replayed.end()) ++v.blocks;
        if (ch == AFM_CH_FW_STATE && skip_state) continue;
        ChannelStats &st = v.stats[ch];
        ++v.messages;
        std::string what;
        bool same = true;
        if (r.inconsistent.count(k)) {
            ++st.differing;
            same = false;
            what = "the recording holds two different answers for it (a repeat differs from the first copy): "
                   "the run itself was not deterministic";
        } else if (rec == r.recorded.end()) {
            ++st.missing_recorded;
            same = false;
            what = "the replay answers it, the recording has no such message";
        } else if (now == r.replayed.end()) {
            ++st.missing_new;
            same = false;
            what = "the recording has it, the replay gave no answer";
        } else {
            same = compare(ch, rec->second, now->second, &st, &what);
        }
        if (!same && !v.first.found) {
            v.first.found = true;
            v.first.key = k;
            v.first.text = what;
        }
    }
    return v;
}

void report(const Options &o, const Outputs &r, const Verdict &v, double secs)
{
    if (o.quiet) return;
    std::printf("replay: %s: %lld events, %lld card inputs, %lld blocks through the card as built now in %.3f s", o.log.c_str(),
                static_cast<long long>(r.events), static_cast<long long>(r.inputs), static_cast<long long>(v.blocks), secs);
    if (o.run_wall_s > 0) std::printf(" (the run took %.2f s: %.0fx faster)", o.run_wall_s, o.run_wall_s / secs);
    std::printf("\n");
    if (!o.log_complete) std::printf("replay: warning: run.json says the log misses analog blocks (the recorder was starved)\n");
    for (const auto &n : r.notes) std::printf("replay: the card says: %s\n", n.c_str());
    if (r.board.value("firmware", "host") == "qemu" && r.board["instructions_per_block"].is_object()) {
        const auto &b = r.board;
        std::printf("replay: the card ran on the board (%s): %.0f instructions a block median, %.0f worst (%.0f and %.0f a sample); "
                    "a round trip %.0f us median\n",
                    b["machine"].get<std::string>().c_str(), b["instructions_per_block"]["median"].get<double>(),
                    b["instructions_per_block"]["worst"].get<double>(), b["instructions_per_sample"]["median"].get<double>(),
                    b["instructions_per_sample"]["worst"].get<double>(), b["round_trip_us"]["median"].get<double>());
    }
    if (r.predates_fw_state)
        std::printf("replay: the recording is of an earlier bus (%lld messages on FW_FORCE, FW_TIP and FW_OBJECTS, "
                    "the channels FW_STATE now holds): FW_STATE is not compared\n",
                    static_cast<long long>(r.before_fw_state));
    if (r.refused_inputs || r.foreign_outputs)
        std::printf("replay: %lld input datagrams refused by the card's inbox (as in the run), %lld datagrams on output channels that "
                    "are not the card's (do not decode, or name a block the card never stepped)\n",
                    static_cast<long long>(r.refused_inputs), static_cast<long long>(r.foreign_outputs));
    for (const auto &w : r.refused_at) std::printf("replay: %s: %s\n", o.log.c_str(), w.c_str());
    if (r.held_back)
        std::printf("replay: %lld inputs were recorded one block early (after a later datagram of another sender) and held "
                    "until the card could take them\n",
                    static_cast<long long>(r.held_back));
    if (r.self_inconsistent)
        std::printf("replay: the recording holds %lld repeated outputs that differ from their first copy\n",
                    static_cast<long long>(r.self_inconsistent));
    if (!o.write.empty()) std::printf("replay: wrote the recorded inputs and the new outputs to %s\n", o.write.c_str());
}

int verdict_line(const Options &o, const Verdict &v)
{
    if (!v.first.found) {
        std::string on;
        for (const auto &c : v.compared) on += (on.empty() ? "" : ", ") + c;
        std::printf("replay: identical: every output of the card as built now equals the recording, bit for bit "
                    "(%lld messages on %s)\n",
                    static_cast<long long>(v.messages), on.c_str());
        return 0;
    }
    const std::string ch = kOutputs[static_cast<std::size_t>(std::get<1>(v.first.key))];
    const int32_t fix = std::get<2>(v.first.key);
    std::printf("replay: DIVERGES: first at block %lld, channel %s%s: %s\n", static_cast<long long>(std::get<0>(v.first.key)),
                ch.c_str(), fix ? (" (fix " + std::to_string(fix) + ")").c_str() : "", v.first.text.c_str());
    if (!o.quiet) {
        std::printf("replay: per channel: messages differing of those compared; missing on either side; worst difference\n");
        for (const auto &c : v.compared) {
            const auto it = v.stats.find(c);
            const ChannelStats s = it == v.stats.end() ? ChannelStats{} : it->second;
            std::printf("  %-13s %7lld of %-7lld  missing: %lld replayed, %lld recorded   worst %.3f pN, %.3f nm\n", c.c_str(),
                        static_cast<long long>(s.differing), static_cast<long long>(s.compared),
                        static_cast<long long>(s.missing_new), static_cast<long long>(s.missing_recorded), s.worst_pN, s.worst_nm);
        }
    }
    return 1;
}

const afm::cli::CommandLine<Options> kCommandLine = {
    "afm_replay",
    std::string(kAfmHelpReplay) + "\n\nThe program behind it (--compare is ./afm's, around it):\n"
        "usage: afm_replay RUN_DIR [--write NEW_LOG] [--scene FILE] [--firmware host|qemu] [--quiet]\n"
        "  Feeds the card inputs recorded in RUN_DIR/bus.lcmlog (AFM_ANALOG, HAPTIC_POSE,\n"
        "  HOST_OBJECT_FIX) into the firmware card as built now and compares every output\n"
        "  (AFM_CMD, HAPTIC_FORCE, FW_STATE) with the recording.\n"
        "  RUN_DIR may also be the log file itself. The scene is RUN_DIR/scene.yaml (the\n"
        "  copy the run kept), or --scene FILE.\n"
        "exit: 0 identical, bit for bit; 1 the outputs differ (the first divergence is named);\n"
        "      2 a bad argument, or a log that is missing, truncated or corrupt (file and byte offset)\n",
    {
        {{"RUN_DIR", nullptr, nullptr, nullptr, true}, afm::cli::text(&Options::run)},
        {{"--write", "NEW_LOG", "options:",
          "write the recorded inputs and the new outputs as an LCM log\n"
          "(lcm-logplayer, ./afm spy NEW_LOG)"},
         afm::cli::text(&Options::write)},
        {{"--scene", "FILE", "options:", "the run's scene (default: RUN_DIR/scene.yaml)"}, afm::cli::text(&Options::scene)},
        {{"--firmware", "host|qemu", "options:",
          "qemu: the card built for its processor, on an emulated mps2-an386\n"
          "board (qemu-system-arm -icount shift=0, docs/pil.md): record on the\n"
          "host, check on the target; prints the board's instructions per block"},
         [](const std::string &v, Options *o) { return afm::read_firmware(v, &o->where.firmware); }},
        {{"--board-elf", "ELF", "options:", "the board's image (default: the build's afm_board.elf)"},
         [](const std::string &v, Options *o) { return afm::cli::read_text(v, &o->where.board_elf); }},
        {{"--quiet", nullptr, "options:", "only the verdict line"}, afm::cli::flag(&Options::quiet)},
    }};

// The run's files from RUN_DIR (locate), and --write not the log replayed;
// a message in *err and false when not.
bool find_run(Options *o, std::string *err)
{
    if (!locate(o->run, o, err)) return false;
    std::error_code ec;
    if (!o->write.empty() && fs::exists(o->write) && fs::equivalent(o->write, o->log, ec))
        return *err = "--write: " + o->write + " is the log being replayed: choose another file", false;
    return true;
}

}  // namespace

// The scene hash the log's launcher recorded (its first heartbeat's detail,
// afm::kScenePrefix), or "" for a log made before runs carried one.
std::string recorded_scene_hash(const std::string &log_path)
{
    afm::LogReader log(log_path);
    log.only({AFM_CH_AFM_HEARTBEAT});
    afm::LogEvent ev;
    for (int n = 0; n < 1000 && log.read(&ev); ++n) {
        afm::heartbeat_t hb;
        if (hb.decode(ev.data.data(), 0, static_cast<int>(ev.data.size())) < 0 || hb.name != "launcher") continue;
        const auto at = hb.detail.find(afm::kScenePrefix);
        return at == std::string::npos ? "" : hb.detail.substr(at + std::string(afm::kScenePrefix).size());
    }
    return "";
}

// A log replays against its own run's scene only: a log from another
// scene's run (or a --scene that is not the run's) is refused, naming both
// hashes; a log without one is replayed with a warning.
bool scene_matches_log(const Options &o)
{
    (void)afm::load_scene(o.scene);   // a scene file that is not one is named first (a FIFO, a directory, a bad scene)
    std::ifstream f(o.scene);
    std::stringstream text;
    text << f.rdbuf();
    const std::string have = afm::scene_hash(text.str()), want = recorded_scene_hash(o.log);
    if (want.empty()) {
        std::fprintf(stderr, "afm_replay: warning: %s was recorded before runs carried their scene's hash: the scene %s is "
                     "taken as the run's without a check\n", o.log.c_str(), o.scene.c_str());
        return true;
    }
    if (want == have) return true;
    std::fprintf(stderr, "afm_replay: %s was recorded with the scene %s, but %s is %s: a log of another scene's run "
                 "(give the run's own scene.yaml)\n", o.log.c_str(), want.c_str(), o.scene.c_str(), have.c_str());
    return false;
}

int main(int argc, char **argv)
{
    Options o;
    if (const int code = afm::cli::read_command_line(kCommandLine, argc, argv, &o); code >= 0) return code;   // --help, or a refusal
    std::string err;
    if (!find_run(&o, &err)) {
        std::fprintf(stderr, "afm_replay: %s\n", err.c_str());
        return afm::kExitInput;
    }
    const auto t0 = std::chrono::steady_clock::now();
    Outputs r;
    try {
        if (!scene_matches_log(o)) return 2;
        r = run_replay(o);
    } catch (const std::exception &e) {   // a scene, log or writer error: named there
        std::fprintf(stderr, "afm_replay: %s\n", e.what());
        return 2;
    }
    const Verdict v = compare_all(r);
    if (v.messages == 0) {
        std::fprintf(stderr, "afm_replay: %s: the log holds no card inputs or outputs to compare\n", o.log.c_str());
        return 2;
    }
    report(o, r, v, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return verdict_line(o, v);
}
