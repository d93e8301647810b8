// The report's one pass over a log (log_series_c.h): LogReader frames the
// events, the generated types decode them, ObjectsView makes the objects
// whole; each particle's card-minus-truth difference is made, weighed and
// decimated here; rows go out in chunks.
#include "log_series_c.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <map>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "afm/fw_state_t.hpp"
#include "afm/sim_truth_t.hpp"
#include "afm_channels.h"
#include "lcmlog.hpp"
#include "objects_view.hpp"

namespace {

constexpr int kBlockCols = 9;   // channel, seq, utime_us, force_nN_x/y/z, tip_nm_x/y/z
constexpr int kDiffCols = 4;    // id, utime_us, dx_nm, dy_nm
constexpr int kStatCols = 9;    // id, n, w, sum_x, sum_y, sq_x, sq_y, worst_x, worst_y
constexpr int64_t kMaxSeqBits = int64_t(1) << 31;   // seqs past this are not deduplicated (a bit each below)
constexpr std::size_t kNone = ~std::size_t(0);

using DiffRow = std::array<double, kDiffCols>;

// a when take, else b, without a branch (the bits selected by a mask).
inline double pick(bool take, double a, double b)
{
    uint64_t ia, ib;
    std::memcpy(&ia, &a, sizeof ia);
    std::memcpy(&ib, &b, sizeof ib);
    const uint64_t mask = uint64_t(0) - uint64_t(take);
    const uint64_t out = (ia & mask) | (ib & ~mask);
    double d;
    std::memcpy(&d, &out, sizeof d);
    return d;
}

// One particle: where each side (0 card, 1 truth) has it, the difference
// holding since `covered`, its running figures, and the time bin being
// decimated (its extremes: least dx, greatest dx, least dy, greatest dy).
struct Pair {
    int32_t id = 0;
    double pos[2][2] = {{0, 0}, {0, 0}};
    bool has[2] = {false, false};
    bool holding = false;
    double covered = 0, d[2] = {0, 0};
    long n = 0;
    double w = 0, sum[2] = {0, 0}, sq[2] = {0, 0}, worst[2] = {0, 0};
    int64_t bin = -1;
    DiffRow ext[4] = {};
};

// One channel's objects: the reader, the last set's drift, and which Pair
// each position of the whole set held last (the publisher keeps its order).
struct Side {
    afm::ObjectsView view;
    std::vector<std::size_t> slot;
    double drift[2] = {0, 0};
    bool any = false;
};

struct Reader {
    afm::LogReader log;
    double bin_us, per_bin;   // per_bin: 1 / bin_us (a power of two's inverse is exact)
    Side sides[2];
    std::vector<Pair> pairs;
    std::unordered_map<int32_t, std::size_t> index;   // particle id -> pairs
    std::vector<bool> seen[2];                        // seq -> a block row went out
    std::deque<DiffRow> diffs;                        // rows made, not yet taken
    double t_end = 0;                                 // the last message's utime
    long undecodable = 0, refused = 0;
    long long recorded[2] = {0, 0};   // the first and the last event's recording time
    bool ended = false;

    Reader(const std::string &path, double bin) : log(path), bin_us(bin > 0 && std::isfinite(bin) ? bin : 0),
          per_bin(bin_us > 0 ? 1 / bin_us : 0)
    {
        log.only({AFM_CH_FW_STATE, AFM_CH_SIM_TRUTH});
    }

    bool first_of_block(int ch, int64_t seq)
    {
        if (seq < 0 || seq >= kMaxSeqBits) return true;
        auto &s = seen[ch];
        if (static_cast<std::size_t>(seq) >= s.size()) s.resize(static_cast<std::size_t>(seq) * 2 + 1024);
        if (s[static_cast<std::size_t>(seq)]) return false;
        s[static_cast<std::size_t>(seq)] = true;
        return true;
    }

    // The Pair of particle `id`, at position k of side ch's whole set.
    Pair &pair_at(int ch, std::size_t k, int32_t id)
    {
        auto &slot = sides[ch].slot;
        if (slot.size() <= k) slot.resize(k + 1, kNone);
        if (slot[k] != kNone && pairs[slot[k]].id == id) return pairs[slot[k]];
        auto [it, fresh] = index.try_emplace(id, pairs.size());
        if (fresh) {
            pairs.emplace_back();
            pairs.back().id = id;
        }
        slot[k] = it->second;
        return pairs[it->second];
    }

    // The difference holding until t ends: weighed into the figures.
    static void close(Pair &q, double t)
    {
        const double w = std::max(0.0, t - q.covered);
        ++q.n;
        q.w += w;
        for (int a = 0; a < 2; ++a) {
            q.sum[a] += w * q.d[a];
            q.sq[a] += w * q.d[a] * q.d[a];
            q.worst[a] = std::max(q.worst[a], std::fabs(q.d[a]));
        }
        q.covered = std::max(q.covered, t);
    }

    // The bin's extremes out, in time order, each row once.
    void flush(Pair &q)
    {
        if (q.bin < 0) return;
        DiffRow rows[4];
        std::copy(std::begin(q.ext), std::end(q.ext), rows);
        std::sort(std::begin(rows), std::end(rows));
        for (int k = 0; k < 4; ++k)
            if (k == 0 || rows[k] != rows[k - 1]) diffs.push_back(rows[k]);
        q.bin = -1;
    }

    // A difference (id, t, x, y): handed on, or kept while it is one of its
    // bin's extremes (selects, not branches: a noisy difference would
    // mispredict most of them).
    void keep(Pair &q, const DiffRow &r)
    {
        if (bin_us <= 0) {
            diffs.push_back(r);
            return;
        }
        const auto b = static_cast<int64_t>(std::max(0.0, r[1]) * per_bin);
        if (b != q.bin) {
            if (b < q.bin) {   // a row late into a bin already let out (the card's block after the truth's next)
                diffs.push_back(r);
                return;
            }
            flush(q);
            q.bin = b;
            std::fill(std::begin(q.ext), std::end(q.ext), r);
            return;
        }
        for (int k = 0; k < 4; ++k) {
            const int c = 2 + k / 2;
            const bool take = k % 2 == 0 ? r[c] < q.ext[k][c] : r[c] > q.ext[k][c];
            for (int j = 1; j < kDiffCols; ++j) q.ext[k][j] = pick(take, r[j], q.ext[k][j]);
        }
    }

    // Side ch placed particle p (at position k of its whole set) at time t.
    void particle(int ch, std::size_t k, double t, const afm::particle_t &p)
    {
        Pair &q = pair_at(ch, k, p.id);
        if (q.has[ch] && q.pos[ch][0] == p.x_nm && q.pos[ch][1] == p.y_nm) return;
        q.has[ch] = true;
        q.pos[ch][0] = p.x_nm;
        q.pos[ch][1] = p.y_nm;
        if (!q.has[1 - ch]) return;
        if (q.holding) close(q, t);
        else q.covered = t;
        q.holding = true;
        q.d[0] = q.pos[0][0] - q.pos[1][0];
        q.d[1] = q.pos[0][1] - q.pos[1][1];
        keep(q, {double(q.id), t, q.d[0], q.d[1]});
    }

    // The set after message m was placed: every particle when m is complete
    // or the drift moved them all, else those m lists (the others are where
    // they were: objects_t.lcm).
    void placed(int ch, const afm::objects_t &m)
    {
        Side &sd = sides[ch];
        const afm::objects_t &whole = sd.view.whole();
        const double t = double(whole.utime);
        t_end = std::max(t_end, t);
        const bool all = m.complete || !sd.any || whole.drift_nm[0] != sd.drift[0] || whole.drift_nm[1] != sd.drift[1];
        if (all) {
            for (std::size_t k = 0; k < whole.particles.size(); ++k) particle(ch, k, t, whole.particles[k]);
        } else {
            for (const auto &listed : m.particles)
                for (std::size_t k = 0; k < whole.particles.size(); ++k)   // listed: few; its whole state
                    if (whole.particles[k].id == listed.id) {
                        particle(ch, k, t, whole.particles[k]);
                        break;
                    }
        }
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
        t_end = std::max(t_end, double(m.utime));
        objects(ch, m.objects);
        if (!first_of_block(ch, m.seq)) return false;
        const double row[kBlockCols] = {double(ch), double(m.seq), double(m.utime), m.force_nN[0], m.force_nN[1],
                                        m.force_nN[2], m.tip_nm[0], m.tip_nm[1], m.tip_nm[2]};
        std::memcpy(out, row, sizeof row);
        return true;
    }

    void finish()
    {
        for (auto &q : pairs) {
            if (q.holding) close(q, t_end);
            flush(q);
        }
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
    if (!std::strcmp(kind, "diffs")) return "id,utime_us,x_nm,y_nm";
    if (!std::strcmp(kind, "stats")) return "id,n,w,sum_x,sum_y,sq_x,sq_y,worst_x,worst_y";
    return nullptr;
}

void *afm_log_series_open(const char *path, double bin_us, char *err, size_t err_len)
{
    try {
        return new Reader(path ? path : "", bin_us);
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
        while (n < cap && !r->ended && r->diffs.size() < AFM_LOG_SERIES_MAX_WAITING) {
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

long afm_log_series_diffs(void *reader, double *rows, long cap)
{
    auto *r = static_cast<Reader *>(reader);
    if (!r || !rows || cap <= 0) return 0;
    long n = 0;
    for (; n < cap && !r->diffs.empty(); ++n) {
        std::memcpy(rows + n * kDiffCols, r->diffs.front().data(), sizeof(DiffRow));
        r->diffs.pop_front();
    }
    return n;
}

long afm_log_series_stats(void *reader, double *rows, long cap)
{
    auto *r = static_cast<Reader *>(reader);
    if (!r || !rows || cap <= 0) return 0;
    std::map<int32_t, const Pair *> by_id;
    for (const auto &q : r->pairs)
        if (q.n > 0) by_id[q.id] = &q;
    long n = 0;
    for (const auto &[id, q] : by_id) {
        if (n == cap) break;
        const double row[kStatCols] = {double(id), double(q->n), q->w, q->sum[0], q->sum[1],
                                       q->sq[0], q->sq[1], q->worst[0], q->worst[1]};
        std::memcpy(rows + n * kStatCols, row, sizeof row);
        ++n;
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
