// The scene's objects (particles listed and scattered, wires, landmarks,
// targets) and the checks of where they lie and where the path starts
// (scene_reader.hpp).
#include "scene_reader.hpp"

namespace afm {

double point_segment_distance(Vec2 p, Vec2 a, Vec2 b)
{
    const double dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
    const double t = l2 > 0 ? std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / l2, 0.0, 1.0) : 0.0;
    return std::hypot(p.x - a.x - t * dx, p.y - a.y - t * dy);
}

}  // namespace afm

namespace afm::scene_detail {


// objects.scatter: particles drawn at random, the bench's own generator
// (xorshift64*), so every process and machine draws the same ones.
// Listed objects, at most (scattered particles: objects.scatter.count <=
// 5000, the scatter's O(count^2)); a 50 MB scene listing 923k particles
// took 3.9 GB before any answer.
constexpr std::size_t kMaxListedParticles = 5000, kMaxListedWires = 1000, kMaxListedLandmarks = 1000;

void read_scatter(const Reader &r, const YAML::Node &n, Scene &s)
{
    if (!n.IsDefined() || n.IsNull()) return;
    const std::string k = "objects.scatter";
    r.only_keys(n, k, {"count", "radius_nm", "region_nm", "min_gap_nm", "seed"});
    ScatterSpec &c = s.scatter;
    const double count = r.num(n, k, "count", nullptr);
    c.count = static_cast<int>(count);
    const ScatterSpec d;
    c.radius_nm = r.num(n, k, "radius_nm", &d.radius_nm);
    c.min_gap_nm = r.num(n, k, "min_gap_nm", &d.min_gap_nm);
    const double seed_d = 1;
    const double seed = r.num(n, k, "seed", &seed_d);
    c.seed = static_cast<uint64_t>(seed);
    const double half = s.field_nm / 2;
    YAML::Node reg = n["region_nm"];
    if (!reg.IsDefined()) {
        c.lo_nm = {s.field_center_nm.x - half, s.field_center_nm.y - half};
        c.hi_nm = {s.field_center_nm.x + half, s.field_center_nm.y + half};
    } else {
        if (!reg.IsSequence() || reg.size() != 4) r.fail(k + ".region_nm", "must be [x0, y0, x1, y1], got " + Reader::show(reg));
        c.lo_nm = {r.check_num(reg[0], k + ".region_nm[0]"), r.check_num(reg[1], k + ".region_nm[1]")};
        c.hi_nm = {r.check_num(reg[2], k + ".region_nm[2]"), r.check_num(reg[3], k + ".region_nm[3]")};
        if (!(c.hi_nm.x > c.lo_nm.x && c.hi_nm.y > c.lo_nm.y))
            r.fail(k + ".region_nm", "must have x1 > x0 and y1 > y0, got " + Reader::show(reg));
    }
    uint64_t st = c.seed ? c.seed : 0x9E3779B97F4A7C15ull;
    auto unit = [&st] {   // xorshift64*: [0, 1)
        st ^= st >> 12;
        st ^= st << 25;
        st ^= st >> 27;
        return static_cast<double>((st * 0x2545F4914F6CDD1Dull) >> 11) * (1.0 / 9007199254740992.0);
    };
    int next_id = 1;
    for (const auto &p : s.particles) next_id = std::max(next_id, p.id + 1);
    for (const auto &m : s.landmarks) next_id = std::max(next_id, m.id + 1);
    for (int i = 0; i < c.count; ++i) {
        bool placed = false;
        for (int attempt = 0; attempt < 2000 && !placed; ++attempt) {
            const double x = c.lo_nm.x + c.radius_nm + unit() * (c.hi_nm.x - c.lo_nm.x - 2 * c.radius_nm);
            const double y = c.lo_nm.y + c.radius_nm + unit() * (c.hi_nm.y - c.lo_nm.y - 2 * c.radius_nm);
            placed = std::all_of(s.particles.begin(), s.particles.end(), [&](const ParticleSpec &o) {
                return std::hypot(o.x_nm - x, o.y_nm - y) >= o.radius_nm + c.radius_nm + c.min_gap_nm;
            }) && std::all_of(s.wires.begin(), s.wires.end(), [&](const WireSpec &w) {
                const double ax = w.x1_nm - w.x0_nm, ay = w.y1_nm - w.y0_nm, l2 = ax * ax + ay * ay;
                const double t = std::clamp(((x - w.x0_nm) * ax + (y - w.y0_nm) * ay) / l2, 0.0, 1.0);
                return std::hypot(x - w.x0_nm - t * ax, y - w.y0_nm - t * ay) >= w.diameter_nm / 2 + c.radius_nm + c.min_gap_nm;
            }) && std::all_of(s.landmarks.begin(), s.landmarks.end(), [&](const LandmarkSpec &m) {
                return std::hypot(m.x_nm - x, m.y_nm - y) >= m.side_nm * M_SQRT1_2 + c.radius_nm + c.min_gap_nm;
            });
            if (placed) s.particles.push_back({next_id++, x, y, c.radius_nm});
        }
        if (!placed)
            r.fail(k, "cannot place particle " + std::to_string(i + 1) + " of " + std::to_string(c.count) + " with min_gap_nm " +
                          Reader::show(n["min_gap_nm"]) + " in the region: give a larger region or fewer particles");
    }
}

// objects.targets[i].particle: a particle of the scene (listed or
// scattered), pinned to one site only.
int read_pin(const Reader &r, const YAML::Node &n, const std::string &key, const Scene &s)
{
    if (!n.IsDefined()) r.fail(key, "missing: a site given as a mapping names the particle that must go there");
    if (!n.IsScalar()) r.fail(key, "must be a particle id, got " + Reader::show(n));
    const double v = r.check_num(n, key);
    const int id = static_cast<int>(v);
    if (std::none_of(s.particles.begin(), s.particles.end(), [&](const ParticleSpec &p) { return p.id == id; }))
        r.fail(key, "names no particle of the scene (objects.particles, objects.scatter), got " + Reader::show(n));
    for (std::size_t j = 0; j < s.targets.pinned.size(); ++j)
        if (s.targets.pinned[j] == id)
            r.fail(key, "particle " + std::to_string(id) + " is pinned to objects.targets[" + std::to_string(j) + "] already: one site per particle");
    return id;
}

// objects.targets: a list of sites ([x, y], or {x_nm, y_nm, particle}), or
// {text | png, pitch_nm, height_nm, center_nm} (rasterised by
// host/pattern.hpp).
void read_targets(const Reader &r, const YAML::Node &n, Scene &s)
{
    if (!n.IsDefined() || n.IsNull()) return;
    const std::string k = "objects.targets";
    const double half = s.field_nm / 2;
    TargetSpec &t = s.targets;
    if (n.IsSequence()) {
        for (std::size_t i = 0; i < n.size(); ++i) {
            const std::string key = k + "[" + std::to_string(i) + "]";
            const bool pin = n[i].IsMap();
            if (pin) r.only_keys(n[i], key, {"x_nm", "y_nm", "particle"});
            const Vec2 v = pin ? Vec2{r.num(n[i], key, "x_nm", nullptr), r.num(n[i], key, "y_nm", nullptr)}
                               : r.vec2(n[i], key);
            if (std::fabs(v.x - s.field_center_nm.x) > half || std::fabs(v.y - s.field_center_nm.y) > half)
                r.fail(key, "target " + Reader::show(n[i]) + " is outside the field");
            t.sites_nm.push_back(v);
            t.pinned.push_back(pin ? read_pin(r, n[i]["particle"], key + ".particle", s) : -1);
        }
        if (t.sites_nm.empty()) r.fail(k, "the list of targets is empty");
        return;
    }
    r.only_keys(n, k, {"text", "png", "pitch_nm", "height_nm", "center_nm"});
    const std::string none;
    t.text = r.str(n, k, "text", &none);
    t.png = r.str(n, k, "png", &none);
    if (t.text.empty() == t.png.empty()) r.fail(k, "give one of text or png (or a list of [x, y] sites)");
    if (!t.png.empty() && t.png[0] != '/') {
        const auto slash = s.file.find_last_of('/');
        t.png = (slash == std::string::npos ? std::string(".") : s.file.substr(0, slash)) + "/" + t.png;
    }
    const TargetSpec d;
    t.pitch_nm = r.num(n, k, "pitch_nm", &d.pitch_nm);
    t.height_nm = r.num(n, k, "height_nm", &d.height_nm);
    t.center_nm = s.field_center_nm;
    if (n["center_nm"].IsDefined()) t.center_nm = r.vec2(n["center_nm"], k + ".center_nm");
}

void read_wire_targets(const Reader &r, const YAML::Node &n, Scene &s)
{
    if (!n.IsDefined() || n.IsNull()) return;
    const std::string k = "objects.wire_targets";
    if (!n.IsSequence()) r.fail(k, "must be a list, got " + Reader::show(n));
    for (std::size_t i = 0; i < n.size(); ++i) {
        const std::string p = k + "[" + std::to_string(i) + "]";
        r.only_keys(n[i], p, {"id", "x_nm", "y_nm", "angle_deg"});
        WireTargetSpec w;
        const double id = r.num(n[i], p, "id", nullptr);
        w.id = static_cast<int>(id);
        for (const auto &o : s.wire_targets)
            if (o.id == w.id) r.fail(p + ".id", "a second target for wire " + Reader::show(n[i]["id"]));
        w.x_nm = r.num(n[i], p, "x_nm", nullptr);
        w.y_nm = r.num(n[i], p, "y_nm", nullptr);
        w.angle_deg = r.num(n[i], p, "angle_deg", nullptr);
        if (std::none_of(s.wires.begin(), s.wires.end(), [&](const WireSpec &x) { return x.id == w.id; }))
            r.fail(p + ".id", "names no wire of objects.wires, got " + Reader::show(n[i]["id"]));
        s.wire_targets.push_back(w);
    }
}

// objects: particles, wires and landmarks, inside the field.
// objects.particles: listed particles, their ids unique, inside the field.
void read_particles(const Reader &r, const YAML::Node &ps, Scene &s)
{
    if (ps.IsDefined() && !ps.IsNull()) {
        if (!ps.IsSequence()) r.fail("objects.particles", "must be a list, got " + Reader::show(ps));
        if (ps.size() > kMaxListedParticles)
            r.fail("objects.particles", "lists " + std::to_string(ps.size()) + " particles; at most " +
                                            std::to_string(kMaxListedParticles) + " (as objects.scatter.count)");
        for (std::size_t i = 0; i < ps.size(); ++i) {
            const std::string p = "objects.particles[" + std::to_string(i) + "]";
            r.only_keys(ps[i], p, {"id", "x_nm", "y_nm", "radius_nm"});
            ParticleSpec q;
            const double id = r.num(ps[i], p, "id", nullptr);
            q.id = static_cast<int>(id);
            q.x_nm = r.num(ps[i], p, "x_nm", nullptr);
            q.y_nm = r.num(ps[i], p, "y_nm", nullptr);
            q.radius_nm = r.num(ps[i], p, "radius_nm", nullptr);
            for (const auto &o : s.particles)
                if (o.id == q.id) r.fail(p + ".id", "duplicate particle id " + Reader::show(ps[i]["id"]));
            s.particles.push_back(q);
        }
    }
}

void read_objects(const Reader &r, const YAML::Node &root, Scene &s)
{
    YAML::Node obj = root["objects"];
    if (obj.IsDefined() && !obj.IsNull()) {
        r.only_keys(obj, "objects", {"particles", "wires", "landmarks", "scatter", "targets", "wire_targets"});
        read_particles(r, obj["particles"], s);
        YAML::Node ws = obj["wires"];
        if (ws.IsDefined() && !ws.IsNull()) {
            if (!ws.IsSequence()) r.fail("objects.wires", "must be a list, got " + Reader::show(ws));
            if (ws.size() > kMaxListedWires)
                r.fail("objects.wires", "lists " + std::to_string(ws.size()) + " wires; at most " + std::to_string(kMaxListedWires));
            for (std::size_t i = 0; i < ws.size(); ++i) {
                const std::string p = "objects.wires[" + std::to_string(i) + "]";
                r.only_keys(ws[i], p, {"id", "x0_nm", "y0_nm", "x1_nm", "y1_nm", "diameter_nm"});
                WireSpec w;
                const double id = r.num(ws[i], p, "id", nullptr);
                w.id = static_cast<int>(id);
                w.x0_nm = r.num(ws[i], p, "x0_nm", nullptr);
                w.y0_nm = r.num(ws[i], p, "y0_nm", nullptr);
                w.x1_nm = r.num(ws[i], p, "x1_nm", nullptr);
                w.y1_nm = r.num(ws[i], p, "y1_nm", nullptr);
                w.diameter_nm = r.num(ws[i], p, "diameter_nm", nullptr);
                if (std::hypot(w.x1_nm - w.x0_nm, w.y1_nm - w.y0_nm) < w.diameter_nm)
                    r.fail(p, "a wire must be longer than its diameter, got length " +
                                  std::to_string(std::hypot(w.x1_nm - w.x0_nm, w.y1_nm - w.y0_nm)) + " nm");
                for (const auto &o : s.wires)
                    if (o.id == w.id) r.fail(p + ".id", "duplicate wire id " + Reader::show(ws[i]["id"]));
                s.wires.push_back(w);
            }
        }
        YAML::Node ls = obj["landmarks"];
        if (ls.IsDefined() && !ls.IsNull()) {
            if (!ls.IsSequence()) r.fail("objects.landmarks", "must be a list, got " + Reader::show(ls));
            if (ls.size() > kMaxListedLandmarks)
                r.fail("objects.landmarks",
                       "lists " + std::to_string(ls.size()) + " landmarks; at most " + std::to_string(kMaxListedLandmarks));
            for (std::size_t i = 0; i < ls.size(); ++i) {
                const std::string p = "objects.landmarks[" + std::to_string(i) + "]";
                r.only_keys(ls[i], p, {"id", "x_nm", "y_nm", "side_nm", "height_nm"});
                LandmarkSpec m;
                const double id = r.num(ls[i], p, "id", nullptr);
                m.id = static_cast<int>(id);
                m.x_nm = r.num(ls[i], p, "x_nm", nullptr);
                m.y_nm = r.num(ls[i], p, "y_nm", nullptr);
                const LandmarkSpec dl;
                m.side_nm = r.num(ls[i], p, "side_nm", &dl.side_nm);
                m.height_nm = r.num(ls[i], p, "height_nm", &dl.height_nm);
                for (const auto &o : s.particles)
                    if (o.id == m.id) r.fail(p + ".id", "landmark id " + Reader::show(ls[i]["id"]) + " is also a particle's id");
                for (const auto &o : s.landmarks)
                    if (o.id == m.id) r.fail(p + ".id", "duplicate landmark id " + Reader::show(ls[i]["id"]));
                s.landmarks.push_back(m);
            }
        }
        read_scatter(r, obj["scatter"], s);
        read_targets(r, obj["targets"], s);
        read_wire_targets(r, obj["wire_targets"], s);
    }
}


// Distance between segments [a, b] and [c, d], nm.
double segment_gap(Vec2 a, Vec2 b, Vec2 c, Vec2 d)
{
    const auto point_seg = point_segment_distance;
    auto cross = [](Vec2 o, Vec2 p, Vec2 q) { return (p.x - o.x) * (q.y - o.y) - (p.y - o.y) * (q.x - o.x); };
    const double d1 = cross(a, b, c), d2 = cross(a, b, d), d3 = cross(c, d, a), d4 = cross(c, d, b);
    if (((d1 > 0) != (d2 > 0)) && ((d3 > 0) != (d4 > 0))) return 0.0;   // they cross
    return std::min({point_seg(a, c, d), point_seg(b, c, d), point_seg(c, a, b), point_seg(d, a, b)});
}

std::string particle_key(const Scene &s, std::size_t i)
{
    const std::size_t listed = s.particles.size() - static_cast<std::size_t>(s.scatter.count > 0 ? s.scatter.count : 0);
    return i < listed ? "objects.particles[" + std::to_string(i) + "]"
                      : "objects.scatter (particle id " + std::to_string(s.particles[i].id) + ")";
}

// A distance as the overlap and path-start refusals quote it: nm, one decimal.
static std::string fmt(double v)
{
    char b[32];
    std::snprintf(b, sizeof b, "%.1f", v);
    return std::string(b);
}

// Two bodies cannot start in one place: particles that overlap or coincide,
// a particle on a wire or a landmark, wires that touch or cross
// (object_pairs_within, the one owner of the geometry). The scattered
// particles keep their gaps by construction; listed ones are checked here,
// pairwise (at most kMaxListedParticles of them). Touching is allowed
// here; ./afm check warns of it.
void check_overlaps(const Reader &r, const Scene &s)
{
    for (const ObjectPair &p : object_pairs_within(s, 1e-9)) {
        const std::string j = " (id " + std::to_string(p.id_j) + ")";
        switch (p.kind) {
        case ObjectPair::Kind::particles:
            if (p.gap_nm < -1e-9)
                r.fail(p.key_i, "overlaps " + p.key_j + j + ": centres " + fmt(p.apart_nm) + " nm apart, radii " +
                                    fmt(s.particles[p.i].radius_nm) + " + " + fmt(s.particles[p.j].radius_nm) + " nm");
            break;
        case ObjectPair::Kind::particle_wire:
            if (p.gap_nm < -1e-9)
                r.fail(p.key_i, "lies on " + p.key_j + j + ": " + fmt(p.apart_nm) + " nm from its axis, closer than " +
                                    fmt(p.apart_nm - p.gap_nm) + " nm");
            break;
        case ObjectPair::Kind::particle_landmark:
            if (p.gap_nm < -1e-9) r.fail(p.key_i, "lies on " + p.key_j + j);
            break;
        case ObjectPair::Kind::wires:
            if (p.gap_nm < -1e-9) r.fail(p.key_i, "touches or crosses " + p.key_j + j + ": axes " + fmt(p.apart_nm) + " nm apart");
        }
    }
}

// A path that starts with the apex inside a particle or a wire: the
// simulator would throw the object clear in the first sample (tens of nm,
// unasked). Refused, naming the start and the object; touching is allowed.
// Only when the run starts engaged (a planned run starts lifted).
void check_path_start(const Reader &r, const Scene &s)
{
    if (!s.start_engaged() || s.op.path_nm.empty()) return;
    const Vec2 a = s.op.path_nm.front();
    const double R = s.probe.tip_radius_nm;
    const std::string key = "operator.path_nm[0]";
    for (std::size_t i = 0; i < s.particles.size(); ++i) {
        const ParticleSpec &p = s.particles[i];
        const double d = std::hypot(a.x - p.x_nm, a.y - p.y_nm);
        if (d < p.radius_nm + R - 1e-9)
            r.fail(key, "starts inside " + particle_key(s, i) + " (id " + std::to_string(p.id) + "): the apex's centre " + fmt(d) +
                            " nm from the particle's, closer than its radius " + fmt(p.radius_nm) + " + the tip's " + fmt(R) +
                            " nm; start the path outside it");
    }
    for (std::size_t k = 0; k < s.wires.size(); ++k) {
        const WireSpec &w = s.wires[k];
        const double d = segment_gap(a, a, {w.x0_nm, w.y0_nm}, {w.x1_nm, w.y1_nm});
        if (d < w.diameter_nm / 2 + R - 1e-9)
            r.fail(key, "starts inside objects.wires[" + std::to_string(k) + "] (id " + std::to_string(w.id) + "): the apex's centre " +
                            fmt(d) + " nm from its axis, closer than half its diameter " + fmt(w.diameter_nm / 2) + " + the tip's " +
                            fmt(R) + " nm; start the path outside it");
    }
}

}  // namespace afm::scene_detail

namespace afm {

std::vector<ObjectPair> object_pairs_within(const Scene &s, double gap_nm)
{
    using scene_detail::particle_key;
    using scene_detail::segment_gap;
    using K = ObjectPair::Kind;
    std::vector<ObjectPair> out;
    auto wire_key = [](std::size_t k) { return "objects.wires[" + std::to_string(k) + "]"; };
    for (std::size_t i = 0; i < s.particles.size(); ++i) {
        const ParticleSpec &p = s.particles[i];
        const Vec2 c{p.x_nm, p.y_nm};
        for (std::size_t j = 0; j < i; ++j) {
            const ParticleSpec &q = s.particles[j];
            const double d = std::hypot(p.x_nm - q.x_nm, p.y_nm - q.y_nm);
            if (d - p.radius_nm - q.radius_nm < gap_nm)
                out.push_back({K::particles, i, j, d, d - p.radius_nm - q.radius_nm, particle_key(s, i), particle_key(s, j), q.id});
        }
        for (std::size_t k = 0; k < s.wires.size(); ++k) {
            const WireSpec &w = s.wires[k];
            const double d = segment_gap(c, c, {w.x0_nm, w.y0_nm}, {w.x1_nm, w.y1_nm});
            if (d - p.radius_nm - w.diameter_nm / 2 < gap_nm)
                out.push_back({K::particle_wire, i, k, d, d - p.radius_nm - w.diameter_nm / 2, particle_key(s, i), wire_key(k), w.id});
        }
        for (std::size_t k = 0; k < s.landmarks.size(); ++k) {
            const LandmarkSpec &m = s.landmarks[k];
            const double dx = std::max(0.0, std::fabs(p.x_nm - m.x_nm) - m.side_nm / 2), dy = std::max(0.0, std::fabs(p.y_nm - m.y_nm) - m.side_nm / 2);
            const double d = std::hypot(dx, dy);
            if (d - p.radius_nm < gap_nm)
                out.push_back({K::particle_landmark, i, k, d, d - p.radius_nm, particle_key(s, i),
                               "objects.landmarks[" + std::to_string(k) + "]", m.id});
        }
    }
    for (std::size_t i = 0; i < s.wires.size(); ++i)
        for (std::size_t j = 0; j < i; ++j) {
            const WireSpec &a = s.wires[i], &b = s.wires[j];
            const double d = segment_gap({a.x0_nm, a.y0_nm}, {a.x1_nm, a.y1_nm}, {b.x0_nm, b.y0_nm}, {b.x1_nm, b.y1_nm});
            const double gap = d - (a.diameter_nm + b.diameter_nm) / 2;
            if (gap < gap_nm)
                out.push_back({K::wires, i, j, d, gap, wire_key(i), wire_key(j), b.id});
        }
    return out;
}

}  // namespace afm
