#include "scene.hpp"
#include "scene_reader.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <cmath>
#include <sys/stat.h>

#include <fstream>
#include <set>
#include <sstream>

namespace afm {

const std::vector<EffectInfo> &known_effects()
{
    static const std::vector<EffectInfo> effects = {
        {"bending_offset", "apex displaced by lever bending and twist"},
        {"photodiode_noise", "white noise on S_n, S_l (default: the lever's thermal level)"},
        {"adhesion", "tip-substrate and particle-substrate adhesion forces"},
        {"tip_convolution", "scans show the surface dilated by the tip"},
        {"particle_contacts", "a pushed particle pushes the particles it touches"},
        {"thermal_drift", "sample drift against the tip: linear plus random walk"},
        {"wire_flexibility", "wires as chains of N bending segments (sample.wire.segments)"},
        {"lithography", "trenches inscribed above a load threshold (sample.lithography)"},
        {"roughness", "random rough substrate (sample.roughness_rms_nm, sample.roughness_corr_nm)"},
        {"down_force", "the cone presses what it pushes: friction rises with the push, the tip squeezes past psi_max"},
        {"piezo_hysteresis", "the scanner's x, y follow their command through a Prandtl-Ishlinskii loop (afm.hysteresis)"},
        {"piezo_creep", "the scanner keeps moving after a step, gamma log10(t / t0) of it (afm.creep)"},
        {"scan_artefacts", "scans show line offsets, the z servo's lag at edges and the scanner's bow (afm.scan_artefacts)"},
        {"z_drift", "the deflection signal's zero drifts: the true load leaves the set point (afm.z_drift)"},
    };
    return effects;
}

using namespace scene_detail;   // the sections' readers (scene_reader.hpp)


Scene load_scene(const std::string &path)
{
    Scene s;
    const Reader r(path, &s);   // bounds of the scene's own from s, as it is read
    const YAML::Node root = resolved_yaml(path);
    r.only_keys(root, "", kTopLevelKeys);
    s.file = path;
    const Scene d;  // defaults
    s.name = r.str(root, "", "name", nullptr);
    const double seed = r.num(root, "", "seed", nullptr);
    s.seed = static_cast<uint64_t>(seed);
    s.duration_s = r.num(root, "", "duration_s", nullptr);
    s.sample_rate_hz = r.num(root, "", "sample_rate_hz", &d.sample_rate_hz);
    s.block_hz = r.num(root, "", "block_hz", &d.block_hz);
    s.frame_rate_hz = r.num(root, "", "frame_rate_hz", &d.frame_rate_hz);
    const std::string lockstep = "lockstep";
    s.time_mode = r.str(root, "", "time_mode", &lockstep, {"lockstep", "realtime"});
    const double spb = s.sample_rate_hz / s.block_hz;
    if (std::fabs(spb - std::round(spb)) > 1e-9 || spb < 1 || spb > 4096)
        r.fail("block_hz", "sample_rate_hz / block_hz must be a whole number of samples per block in 1..4096, got " +
                               Reader::show(root["block_hz"]));
    if (s.frame_rate_hz > s.block_hz)
        r.fail("frame_rate_hz", "must not exceed block_hz, got " + Reader::show(root["frame_rate_hz"]));
    read_effects(r, root, s);
    read_sample(r, root, s);
    read_probe(r, root, s);
    read_firmware(r, root, s);
    read_afm(r, root, s);
    read_objects(r, root, s);
    check_overlaps(r, s);
    read_expect(r, root, s);
    if (s.wire_contact_width_nm() > 0)
        for (const auto &w : s.wires)
            if (w.diameter_nm != s.wires.front().diameter_nm)
                r.fail("sample.wire.contact", "hertz_line gives one friction per length for all wires (the card's model has one): wire " +
                                                  std::to_string(w.id) + " is " + Reader::show(YAML::Node(w.diameter_nm)) +
                                                  " nm across, the first " + Reader::show(YAML::Node(s.wires.front().diameter_nm)));
    read_operator(r, root, s);
    check_path_start(r, s);
    check_plan(r, s);
    read_outputs(r, root, s);
    return s;
}

Vec2 Scene::start_nm() const { return op.path_nm.front(); }

std::vector<double> path_times_s(const Scene &s)
{
    std::vector<double> t;
    for (std::size_t i = 0; i < s.op.path_nm.size(); ++i) {
        const Vec2 a = s.op.path_nm[i ? i - 1 : 0], b = s.op.path_nm[i];
        t.push_back((i ? t.back() : 0.0) + std::hypot(b.x - a.x, b.y - a.y) / s.op.speed_nm_per_s);
    }
    return t;
}

double Scene::load_at_nN(double t_s) const
{
    if (!op.load_ramp_to_nN) return op.load_nN;
    const double a = std::clamp(t_s / duration_s, 0.0, 1.0);
    return op.load_nN + a * (*op.load_ramp_to_nN - op.load_nN);
}

namespace {
// Young's modulus (GPa) and Poisson's ratio of each substrate, and of the
// wire (silver: the modulus is sample.wire.youngs_modulus_GPa).
struct Elastic { double E_GPa, nu; };
Elastic substrate_elastic(const std::string &substrate)
{
    if (substrate == "polycarbonate") return {2.4, 0.37};
    return {70.0, 0.22};   // glass, tilted_glass
}
constexpr double kWirePoisson = 0.37;
}  // namespace

double Scene::wire_adhesion_nN_per_um() const
{
    return wire_model.adhesion_nN_per_um && has_effect("adhesion") ? *wire_model.adhesion_nN_per_um : 0.0;
}

double Scene::wire_contact_width_nm() const
{
    if (!wire_model.adhesion_nN_per_um || wire_model.contact == "none" || wires.empty()) return 0.0;
    const Elastic sub = substrate_elastic(substrate);
    const double inv_E = (1 - kWirePoisson * kWirePoisson) / (wire_model.youngs_modulus_GPa * 1e9) +
                         (1 - sub.nu * sub.nu) / (sub.E_GPa * 1e9);                    // 1 / E*, 1/Pa
    const double P = wire_adhesion_nN_per_um() * 1e-3;                                 // nN/um -> N/m
    const double R = 0.5 * wires.front().diameter_nm * 1e-9;                           // m
    return 2.0 * std::sqrt(4.0 * P * R * inv_E / M_PI) * 1e9;                          // 2 b, nm
}

double Scene::wire_friction_nN_per_um() const
{
    if (!wire_model.adhesion_nN_per_um) return wire_model.friction_nN_per_um;
    // tau [MPa] * A per um = 1e6 N/m^2 * (w [nm] 1e-9 m * 1e-6 m) = w 1e-9 N: tau w nN per um.
    return wire_model.mu * wire_adhesion_nN_per_um() + wire_model.shear_strength_MPa * wire_contact_width_nm();
}

bool Scene::start_engaged() const { return !op.plan.enabled; }

int Scene::samples_per_block() const { return static_cast<int>(std::lround(sample_rate_hz / block_hz)); }

int64_t Scene::total_blocks() const { return static_cast<int64_t>(std::ceil(duration_s * block_hz - 1e-9)); }

int Scene::total_frames() const { return static_cast<int>(std::lround(duration_s * frame_rate_hz)); }

bool Scene::has_effect(const std::string &e) const
{
    return std::find(effects.begin(), effects.end(), e) != effects.end();
}

std::string scene_hash(const std::string &text)
{
    uint64_t h = 14695981039346656037ull;   // FNV-1a, 64 bits
    for (unsigned char c : text) {
        h ^= c;
        h *= 1099511628211ull;
    }
    char buf[32];
    std::snprintf(buf, sizeof buf, "fnv1a64:%016llx", static_cast<unsigned long long>(h));
    return buf;
}

}  // namespace afm

