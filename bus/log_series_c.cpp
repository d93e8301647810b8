// The report's one pass over a log (log_series_c.h): LogReader frames the
// events, the generated types decode them, ObjectsView makes the objects
// whole; rows go out in chunks.
#include "log_series_c.h"

#include <array>
#include <cstdio>
#include <cstring>
#include <deque>
#include <unordered_map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "afm/fw_state_t.hpp"
#include "afm/sim_truth_t.hpp"
#include "afm_channels.h"
#include "lcmlog.hpp"
#include "objects_view.hpp"

namespace {

constexpr int kBlockCols = 9;      // channel, seq, utime_us, force_nN_x/y/z, tip_nm_x/y/z
constexpr int kParticleCols = 7;   // channel, seq, fix_id, utime_us, id, x_nm, y_nm
constexpr int64_t kMaxSeqBits = int64_t(1) << 31;   // seqs past this are not deduplicated (a bit each below)

using ParticleRow = std::array<double, kParticleCols>;

// One particle on one channel: where it is, and the set (seq, fix_id) of
// the last row that went out for it.
struct Track {
    double x = 0, y = 0;
    afm::ObjectsKey sent{};
};

// One channel's objects: the reader, its particles, and the last set placed.
struct Side {
    afm::ObjectsView view;
    std::unordered_map<int32_t, Track> tracks;
    afm::ObjectsKey last{};
    double last_utime = 0;
    double drift[2] = {0, 0};
    bool any = false;
};

struct Reader {
    afm::LogReader log;
    Side sides[2];
    std::vector<bool> seen[2];                  // seq -> a block row went out
    std::deque<ParticleRow> particles;          // rows made, not yet taken
    long undecodable = 0, refused = 0;
    long long recorded[2] = {0, 0};   // the first and the last event's recording time
    bool ended = false;

    explicit Reader(const std::string &path) : log(path) { log.only({AFM_CH_FW_STATE, AFM_CH_SIM_TRUTH}); }

    bool first_of_block(int ch, int64_t seq)
    {
        if (seq < 0 || seq >= kMaxSeqBits) return true;
        auto &s = seen[ch];
        if (static_cast<std::size_t>(seq) >= s.size()) s.resize(static_cast<std::size_t>(seq) * 2 + 1024);
        if (s[static_cast<std::size_t>(seq)]) return false;
        s[static_cast<std::size_t>(seq)] = true;
        return true;
    }

    void row(int ch, afm::ObjectsKey at, double utime, int32_t id, double x, double y)
    {
        particles.push_back({double(ch), double(at.first), double(at.second), utime, double(id), x, y});
    }

    // A particle of the set just placed (key, utime): a row when it is new or
    // moved, after the row that ends its still stretch (the set before).
    void particle(int ch, afm::ObjectsKey key, double utime, const afm::particle_t &p)
    {
        Side &sd = sides[ch];
        auto [it, fresh] = sd.tracks.try_emplace(p.id);
        Track &t = it->second;
        if (!fresh && p.x_nm == t.x && p.y_nm == t.y) return;
        if (!fresh && t.sent != sd.last) row(ch, sd.last, sd.last_utime, p.id, t.x, t.y);
        row(ch, key, utime, p.id, p.x_nm, p.y_nm);
        t = {p.x_nm, p.y_nm, key};
    }

    // The set after message m was placed: every particle when m is complete
    // or the drift moved them all, else those m lists (the others are where
    // they were: objects_t.lcm).
    void placed(int ch, const afm::objects_t &m)
    {
        Side &sd = sides[ch];
        const afm::objects_t &whole = sd.view.whole();
        const afm::ObjectsKey key = afm::key_of(whole);
        const double utime = double(whole.utime);
        const bool all = m.complete || !sd.any || whole.drift_nm[0] != sd.drift[0] || whole.drift_nm[1] != sd.drift[1];
        if (all) {
            for (const auto &p : whole.particles) particle(ch, key, utime, p);
        } else {
            for (const auto &listed : m.particles)
                for (const auto &p : whole.particles)   // listed: few; its whole state
                    if (p.id == listed.id) {
                        particle(ch, key, utime, p);
                        break;
                    }
        }
        sd.last = key;
        sd.last_utime = utime;
        sd.any = true;
        sd.drift[0] = whole.drift_nm[0];
        sd.drift[1] = whole.drift_nm[1];
    }

    void objects(int ch, const afm::objects_t &m)
    {
        const auto told = [&](const afm::objects_t &p) { placed(ch, p); };
        if (sides[ch].view.apply(m, told) == afm::ObjectsView::Take::refused) ++refused;
    }

    // The rows of one message: a block row (when the first of its block) into out.
    template <class M>
    bool message(int ch, const std::vector<uint8_t> &data, double *out)
    {
        M m;
        if (data.size() > 0x7fffffff || m.decode(data.data(), 0, static_cast<int>(data.size())) < 0) {
            ++undecodable;
            return false;
        }
        objects(ch, m.objects);
        if (!first_of_block(ch, m.seq)) return false;
        const double row[kBlockCols] = {double(ch), double(m.seq), double(m.utime), m.force_nN[0], m.force_nN[1],
                                        m.force_nN[2], m.tip_nm[0], m.tip_nm[1], m.tip_nm[2]};
        std::memcpy(out, row, sizeof row);
        return true;
    }

    void finish()
    {
        for (int ch = 0; ch < 2; ++ch)
            for (auto &[id, t] : sides[ch].tracks)
                if (t.sent != sides[ch].last) row(ch, sides[ch].last, sides[ch].last_utime, id, t.x, t.y);
        ended = true;
    }
};

void say(char *err, size_t len, const std::string &what)
{
    if (err && len) std::snprintf(err, len, "%s", what.c_str());
}

}  // namespace

extern "C" {

const char *afm_log_series_columns(const char *kind)
{
    if (!kind) return nullptr;
    if (!std::strcmp(kind, "blocks")) return "channel,seq,utime_us,force_nN_x,force_nN_y,force_nN_z,tip_nm_x,tip_nm_y,tip_nm_z";
    if (!std::strcmp(kind, "particles")) return "channel,seq,fix_id,utime_us,id,x_nm,y_nm";
    return nullptr;
}

void *afm_log_series_open(const char *path, char *err, size_t err_len)
{
    try {
        return new Reader(path ? path : "");
    } catch (const std::exception &e) {
        say(err, err_len, e.what());
    } catch (...) {
        say(err, err_len, "out of memory");
    }
    return nullptr;
}

void afm_log_series_free(void *reader) { delete static_cast<Reader *>(reader); }

long afm_log_series_blocks(void *reader, double *rows, long cap, char *err, size_t err_len)
{
    auto *r = static_cast<Reader *>(reader);
    if (!r || !rows || cap <= 0) return -1;
    try {
        long n = 0;
        afm::LogEvent ev;
        while (n < cap && !r->ended) {
            if (!r->log.read(&ev)) {
                r->finish();
                break;
            }
            if (!r->recorded[0]) r->recorded[0] = ev.utime;
            r->recorded[1] = ev.utime;
            double *out = rows + n * kBlockCols;
            const bool row = ev.channel == AFM_CH_FW_STATE ? r->message<afm::fw_state_t>(0, ev.data, out)
                                                           : r->message<afm::sim_truth_t>(1, ev.data, out);
            n += row;
        }
        return n;
    } catch (const std::exception &e) {
        say(err, err_len, e.what());
    } catch (...) {
        say(err, err_len, "out of memory");
    }
    return -1;
}

long afm_log_series_particles(void *reader, double *rows, long cap)
{
    auto *r = static_cast<Reader *>(reader);
    if (!r || !rows || cap <= 0) return 0;
    long n = 0;
    for (; n < cap && !r->particles.empty(); ++n) {
        std::memcpy(rows + n * kParticleCols, r->particles.front().data(), sizeof(ParticleRow));
        r->particles.pop_front();
    }
    return n;
}

long afm_log_series_undecodable(void *reader) { return reader ? static_cast<Reader *>(reader)->undecodable : 0; }
long long afm_log_series_recorded(void *reader, int which)
{
    return reader && (which == 0 || which == 1) ? static_cast<Reader *>(reader)->recorded[which] : 0;
}
long afm_log_series_refused(void *reader) { return reader ? static_cast<Reader *>(reader)->refused : 0; }

}  // extern "C"
