#include "scene.hpp"
#include "scene_ranges.hpp"
#include "text.hpp"

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
    };
    return effects;
}

namespace {

// The nodes the includes brought into the scene this thread reads
// (merge_missing adds them; resolved_yaml starts the list afresh): an error
// never quotes them, as an included file is never quoted.
thread_local std::vector<YAML::Node> t_included;

// Whether n is tree or inside it (by identity, keys too).
bool within(const YAML::Node &tree, const YAML::Node &n)
{
    if (tree.is(n)) return true;
    if (tree.IsMap()) {
        for (auto it = tree.begin(); it != tree.end(); ++it)
            if (within(it->first, n) || within(it->second, n)) return true;
    } else if (tree.IsSequence()) {
        for (const auto &e : tree)
            if (within(e, n)) return true;
    }
    return false;
}

bool from_include(const YAML::Node &n)
{
    return std::any_of(t_included.begin(), t_included.end(), [&](const YAML::Node &t) { return within(t, n); });
}

// Walks a YAML tree, remembering the key path, so every error names file and key.
class Reader {
public:
    // scene: where bounds of the scene's own (the field, duration_s) are
    // read from, as far as it is read (scene_ranges.hpp)
    explicit Reader(std::string file, const Scene *scene = nullptr) : file_(std::move(file)), scene_(scene) {}

    // `what` is the message's own text with values quoted by show(); the
    // file and the key (a scene's key may be any bytes) are escaped here.
    [[noreturn]] void fail(const std::string &key, const std::string &what) const
    {
        throw SceneError(afm::printable(file_) + ": " + afm::printable(key) + ": " + what);
    }

    // Text a run can write into run.json and a terminal as it is: valid
    // UTF-8 without C0 or C1 control characters (text.hpp's escaper leaves
    // it unchanged but for its backslashes, which are allowed).
    static bool printable_utf8(std::string t)
    {
        t.erase(std::remove(t.begin(), t.end(), '\\'), t.end());
        return afm::printable(t) == t;
    }

    // A value as an error message quotes it: escaped (text.hpp: a scene
    // must not write to the terminal), and at most kShowMax bytes of it (a
    // file included by mistake is not quoted).
    static constexpr std::size_t kShowMax = 80;
    static std::string show(const YAML::Node &n)
    {
        if (!n.IsDefined() || n.IsNull()) return "null";
        if (from_include(n)) return "(a value of an included file: not quoted)";
        if (n.IsScalar()) return "'" + shortened(n.Scalar()) + "'";
        YAML::Emitter e;
        e << YAML::Flow << n;
        return shortened(e.c_str());
    }
    static std::string shortened(const std::string &t)
    {
        if (t.size() <= kShowMax) return afm::printable(t);
        return afm::printable(t.substr(0, kShowMax)) + "... (" + std::to_string(t.size()) + " characters)";
    }

    void only_keys(const YAML::Node &map, const std::string &path, std::set<std::string> allowed) const
    {
        if (!map.IsMap()) fail(path.empty() ? "(top level)" : path, "must be a mapping, got " + show(map));
        std::set<std::string> seen;
        for (auto it = map.begin(); it != map.end(); ++it) {
            if (!it->first.IsScalar()) fail(path.empty() ? "(top level)" : path, "a key must be a name, got " + show(it->first));
            const std::string k = it->first.Scalar();
            // yaml-cpp keeps both copies of a key given twice; the reader would see only the first
            if (!seen.insert(k).second) fail(join(path, k), "given twice");
            if (!allowed.count(k) && from_include(it->first))
                fail(path.empty() ? "(top level)" : path, "an included file has a key not known here (not quoted: an included file)");
            if (!allowed.count(k)) {
                std::string list;
                for (const auto &a : allowed) list += (list.empty() ? "" : ", ") + a;
                fail(join(path, k), "unknown key (known here: " + list + ")");
            }
        }
    }

    static std::string join(const std::string &path, const std::string &k)
    {
        return path.empty() ? k : path + "." + k;
    }

    // The number at map[k], in its kSceneRanges row's range (*dflt when
    // missing; a missing value without a default is refused).
    double num(const YAML::Node &map, const std::string &path, const std::string &k, const double *dflt) const
    {
        const std::string key = join(path, k);
        const SceneRange &range = scene_range(key);   // a key without a row fails here, given or not
        YAML::Node n = map[k];
        if (!n.IsDefined() || n.IsNull()) {
            if (!dflt) fail(key, "required value is missing");
            return *dflt;
        }
        return check_num(n, key, range);
    }

    double check_num(const YAML::Node &n, const std::string &key) const { return check_num(n, key, scene_range(key)); }

    // n as a number in range r: finite, within both ends, whole if r says so.
    double check_num(const YAML::Node &n, const std::string &key, const SceneRange &r) const
    {
        if (!n.IsScalar()) fail(key, "must be a number, got " + show(n));
        double v;
        try {
            v = n.as<double>();
        } catch (const YAML::Exception &) {
            fail(key, "must be a number, got " + show(n));
        }
        if (!std::isfinite(v)) fail(key, "must be a finite number, got " + show(n));
        const double lo = scene_bound(r.lo, scene_), hi = scene_bound(r.hi, scene_);
        const bool low = r.lo_open ? !(v > lo) : !(v >= lo), high = r.hi_open ? !(v < hi) : !(v <= hi);
        if (low || high) {
            std::ostringstream o;
            if (low) o << "must be " << (r.lo_open ? "> " : ">= ") << lo << ", got " << show(n);
            else o << "must be " << (r.hi_open ? "< " : "<= ") << hi << ", got " << show(n);
            fail(key, o.str());
        }
        if (r.whole && v != std::floor(v)) fail(key, std::string("must be ") + r.whole + ", got " + show(n));
        return v;
    }

    std::string str(const YAML::Node &map, const std::string &path, const std::string &k,
                    const std::string *dflt, std::set<std::string> choices = {}) const
    {
        const std::string key = join(path, k);
        YAML::Node n = map[k];
        if (!n.IsDefined() || n.IsNull()) {
            if (!dflt) fail(key, "required value is missing");
            return *dflt;
        }
        if (!n.IsScalar()) fail(key, "must be a string, got " + show(n));
        std::string v = n.Scalar();
        if (!printable_utf8(v)) fail(key, "must be printable UTF-8 text (it is written into run.json)");
        if (!choices.empty() && !choices.count(v)) {
            std::string list;
            for (const auto &c : choices) list += (list.empty() ? "" : ", ") + c;
            fail(key, "must be one of " + list + ", got " + show(n));
        }
        return v;
    }

    Vec2 vec2(const YAML::Node &n, const std::string &key) const
    {
        if (!n.IsSequence() || n.size() != 2) fail(key, "must be a pair [x, y], got " + show(n));
        return Vec2{check_num(n[0], key + "[0]"), check_num(n[1], key + "[1]")};
    }

    bool boolean(const YAML::Node &map, const std::string &path, const std::string &k, bool dflt) const
    {
        YAML::Node n = map[k];
        if (!n.IsDefined() || n.IsNull()) return dflt;
        try {
            return n.as<bool>();
        } catch (const YAML::Exception &) {
            fail(join(path, k), "must be true or false, got " + show(n));
        }
    }

private:
    std::string file_;
    const Scene *scene_;
};

// A material pair's friction and adhesion. with_area: the pair's shear
// strength and contact area too (the particle on the substrate, whose
// sliding threshold the simulator takes as mu F_a + tau A); the tip on the
// substrate slides by Amontons' law alone (mu and adhesion_nN), so those
// two keys, which nothing would read, are refused there by name.
ContactSpec read_contact(const Reader &r, const YAML::Node &n, const std::string &path, ContactSpec d, bool with_area)
{
    if (!n.IsDefined() || n.IsNull()) return d;
    if (!with_area)
        for (const char *k : {"shear_strength_MPa", "contact_area_nm2"})
            if (n[k].IsDefined())
                r.fail(path + "." + k, "not used: the tip slides on the substrate by mu and adhesion_nN alone (a shear strength and "
                                       "contact area belong to sample.particle_substrate)");
    if (with_area)
        r.only_keys(n, path, {"mu", "adhesion_nN", "shear_strength_MPa", "contact_area_nm2"});
    else
        r.only_keys(n, path, {"mu", "adhesion_nN"});
    ContactSpec c;
    c.mu = r.num(n, path, "mu", &d.mu);
    c.adhesion_nN = r.num(n, path, "adhesion_nN", &d.adhesion_nN);
    if (with_area) {
        c.shear_strength_MPa = r.num(n, path, "shear_strength_MPa", &d.shear_strength_MPa);
        c.contact_area_nm2 = r.num(n, path, "contact_area_nm2", &d.contact_area_nm2);
    }
    return c;
}

}  // namespace

namespace {

// effects: the list of effects the simulator builds (known_effects()).
void read_effects(const Reader &r, const YAML::Node &root, Scene &s)
{
    YAML::Node eff = root["effects"];
    if (eff.IsDefined() && !eff.IsNull()) {
        if (!eff.IsSequence()) r.fail("effects", "must be a list of effect names, got " + Reader::show(eff));
        for (std::size_t i = 0; i < eff.size(); ++i) {
            const std::string key = "effects[" + std::to_string(i) + "]";
            if (!eff[i].IsScalar()) r.fail(key, "must be an effect name, got " + Reader::show(eff[i]));
            const std::string e = eff[i].Scalar();
            const auto &known = known_effects();
            auto it = std::find_if(known.begin(), known.end(), [&](const EffectInfo &k) { return e == k.name; });
            if (it == known.end()) {
                std::string list;
                for (const auto &k : known) list += (list.empty() ? "" : ", ") + std::string(k.name);
                r.fail(key, "unknown effect " + Reader::show(eff[i]) + " (known: " + list + ")");
            }
            if (std::find(s.effects.begin(), s.effects.end(), e) != s.effects.end())
                r.fail(key, "effect " + Reader::show(eff[i]) + " is listed twice");
            s.effects.push_back(e);
        }
    }
}

// sample.substrate: a name, or a measured map {gsf: FILE, material:
// glass|polycarbonate (default glass)}; FILE was made absolute against the
// scene's directory by resolved_yaml.
void read_substrate(const Reader &r, const YAML::Node &smp, Scene &s)
{
    const YAML::Node sub = smp["substrate"];
    if (!sub.IsDefined() || !sub.IsMap()) {
        s.substrate = r.str(smp, "sample", "substrate", nullptr, {"glass", "tilted_glass", "polycarbonate"});
        return;
    }
    r.only_keys(sub, "sample.substrate", {"gsf", "material"});
    const std::string glass = "glass";
    s.substrate = r.str(sub, "sample.substrate", "material", &glass, {"glass", "polycarbonate"});
    s.substrate_gsf = r.str(sub, "sample.substrate", "gsf", nullptr);
    if (s.substrate_gsf.empty()) r.fail("sample.substrate.gsf", "must name a GSF file, got ''");
    try {
        s.substrate_map = std::make_shared<const GsfGrid>(read_gsf(s.substrate_gsf));
    } catch (const std::runtime_error &e) {
        r.fail("sample.substrate.gsf", e.what());
    }
    // A height the scanner's z range could not follow is not a substrate.
    for (const float v : s.substrate_map->values)
        if (!(std::fabs(v) * 1e9 <= kScannerRangeZ_nm / 2)) {
            char b[64];
            std::snprintf(b, sizeof b, "%.6g m", static_cast<double>(v));
            r.fail("sample.substrate.gsf", s.substrate_gsf + ": a height of " + b + " is outside the scanner's z range, +-" +
                                               std::to_string(static_cast<int>(kScannerRangeZ_nm / 2)) + " nm");
        }
}

// The map must cover the field (frame A, nm); outside the map the tip meets
// its nearest edge's heights (World::base_measured).
void check_map_covers_field(const Reader &r, const Scene &s)
{
    const GsfGrid &g = *s.substrate_map;
    const double x0 = g.xoff_m * 1e9, y0 = g.yoff_m * 1e9, x1 = x0 + g.xreal_m * 1e9, y1 = y0 + g.yreal_m * 1e9;
    const double h = s.field_nm / 2, cx = s.field_center_nm.x, cy = s.field_center_nm.y;
    const double tol = 1e-6 * s.field_nm;   // the header's 9 significant digits
    if (x0 > cx - h + tol || x1 < cx + h - tol || y0 > cy - h + tol || y1 < cy + h - tol) {
        char b[256];
        std::snprintf(b, sizeof b, "%s covers x [%.6g, %.6g] nm, y [%.6g, %.6g] nm; the field is x [%.6g, %.6g], y [%.6g, %.6g] nm",
                      s.substrate_gsf.c_str(), x0, x1, y0, y1, cx - h, cx + h, cy - h, cy + h);
        r.fail("sample.substrate.gsf", std::string(b) + ": the map must cover the field");
    }
}

// sample: substrate, field, contacts, drift, roughness, wires, lithography.
void read_sample(const Reader &r, const YAML::Node &root, Scene &s)
{
    const Scene d;  // defaults
    YAML::Node smp = root["sample"];
    if (!smp.IsDefined()) r.fail("sample", "required value is missing");
    r.only_keys(smp, "sample", {"substrate", "field_nm", "field_center_nm", "tip_substrate", "particle_substrate",
                                "contact_stiffness_N_per_m", "photodiode_noise_V", "temperature_K",
                                "drift_nm_per_min", "drift_walk_nm_per_sqrt_min", "slope_deg", "wire",
                                "lithography", "roughness_rms_nm", "roughness_corr_nm"});
    read_substrate(r, smp, s);
    if (s.substrate == "tilted_glass") {
        s.slope_deg = r.num(smp, "sample", "slope_deg", nullptr);
    } else if (smp["slope_deg"].IsDefined()) {
        r.fail("sample.slope_deg", "only a tilted_glass substrate has a slope, got " + Reader::show(smp["slope_deg"]));
    }
    YAML::Node wm = smp["wire"];
    if (wm.IsDefined() && !wm.IsNull()) {
        r.only_keys(wm, "sample.wire",
                    {"friction_nN_per_um", "youngs_modulus_GPa", "segments", "friction_points", "relax_sweeps", "mu", "solver",
                     "adhesion_nN_per_um", "shear_strength_MPa", "contact"});
        const WireModelSpec wd;
        if (wm["adhesion_nN_per_um"].IsDefined()) {
            if (wm["friction_nN_per_um"].IsDefined())
                r.fail("sample.wire.friction_nN_per_um", "give either friction_nN_per_um (f) or adhesion_nN_per_um (f derived by eq. 23-24), not both");
            s.wire_model.adhesion_nN_per_um = r.num(wm, "sample.wire", "adhesion_nN_per_um", nullptr);
            s.wire_model.shear_strength_MPa = r.num(wm, "sample.wire", "shear_strength_MPa", &wd.shear_strength_MPa);
            s.wire_model.contact = r.str(wm, "sample.wire", "contact", &wd.contact, {"hertz_line", "none"});
        } else {
            for (const char *k : {"shear_strength_MPa", "contact"})
                if (wm[k].IsDefined())
                    r.fail(std::string("sample.wire.") + k, "belongs to load-dependent friction: give sample.wire.adhesion_nN_per_um too");
            s.wire_model.friction_nN_per_um = r.num(wm, "sample.wire", "friction_nN_per_um", &wd.friction_nN_per_um);
        }
        s.wire_model.youngs_modulus_GPa = r.num(wm, "sample.wire", "youngs_modulus_GPa", &wd.youngs_modulus_GPa);
        s.wire_model.mu = r.num(wm, "sample.wire", "mu", &wd.mu);
        s.wire_model.solver = r.str(wm, "sample.wire", "solver", &wd.solver, {"closed_form", "numeric"});
        auto whole = [&](const char *k, int dflt) {   // a whole number (kSceneRanges)
            const double dv = dflt;
            return static_cast<int>(r.num(wm, "sample.wire", k, &dv));
        };
        s.wire_model.segments = whole("segments", wd.segments);
        s.wire_model.friction_points = whole("friction_points", wd.friction_points);
        s.wire_model.relax_sweeps = whole("relax_sweeps", wd.relax_sweeps);
    }
    YAML::Node li = smp["lithography"];
    if (li.IsDefined() && !li.IsNull()) {
        r.only_keys(li, "sample.lithography", {"threshold_nN", "depth_nm_per_nN"});
        const LithoSpec ld;
        s.litho.threshold_nN = r.num(li, "sample.lithography", "threshold_nN", &ld.threshold_nN);
        s.litho.depth_nm_per_nN = r.num(li, "sample.lithography", "depth_nm_per_nN", &ld.depth_nm_per_nN);
    }
    if (std::find(s.effects.begin(), s.effects.end(), "lithography") != s.effects.end() && s.substrate != "polycarbonate")
        r.fail("sample.substrate", "the lithography effect needs a polycarbonate substrate, got " + Reader::show(smp["substrate"]));
    // The field must lie inside the scanner's range.
    const double range_half = kScannerRangeXY_nm / 2;
    s.field_nm = r.num(smp, "sample", "field_nm", nullptr);
    if (smp["field_center_nm"].IsDefined()) {
        s.field_center_nm = r.vec2(smp["field_center_nm"], "sample.field_center_nm");
        if (std::fabs(s.field_center_nm.x) + s.field_nm / 2 > range_half || std::fabs(s.field_center_nm.y) + s.field_nm / 2 > range_half)
            r.fail("sample.field_center_nm", "the field (field_nm " + Reader::show(smp["field_nm"]) + " around " +
                                                 Reader::show(smp["field_center_nm"]) + ") must lie inside the scanner's range, +-45000 nm");
    }
    if (s.substrate_map) check_map_covers_field(r, s);
    s.tip_substrate = read_contact(r, smp["tip_substrate"], "sample.tip_substrate", ContactSpec{0.0865, 1.0, 0, 0}, false);
    s.particle_substrate = read_contact(r, smp["particle_substrate"], "sample.particle_substrate", ContactSpec{0.3, 3.0, 0, 0}, true);
    s.particle_contact_stiffness_N_per_m = r.num(smp, "sample", "contact_stiffness_N_per_m", &d.particle_contact_stiffness_N_per_m);
    s.photodiode_noise_V = r.num(smp, "sample", "photodiode_noise_V", &d.photodiode_noise_V);
    s.temperature_K = r.num(smp, "sample", "temperature_K", &d.temperature_K);
    if (smp["drift_nm_per_min"].IsDefined()) s.drift_nm_per_min = r.vec2(smp["drift_nm_per_min"], "sample.drift_nm_per_min");
    s.drift_walk_nm_per_sqrt_min = r.num(smp, "sample", "drift_walk_nm_per_sqrt_min", &d.drift_walk_nm_per_sqrt_min);
    s.roughness_rms_nm = r.num(smp, "sample", "roughness_rms_nm", &d.roughness_rms_nm);
    s.roughness_corr_nm = r.num(smp, "sample", "roughness_corr_nm", &d.roughness_corr_nm);
}

// probe: the lever and the tip.
void read_probe(const Reader &r, const YAML::Node &root, Scene &s)
{
    const Scene d;  // defaults
    YAML::Node pr = root["probe"];
    if (pr.IsDefined() && !pr.IsNull()) {
        r.only_keys(pr, "probe", {"spring_N_per_m", "deflection_nm_per_V", "lateral_nN_per_V", "lever_length_um", "tip_height_um",
                                  "tip_radius_nm", "tip_half_angle_deg", "scan_angle_deg", "cn_nm_per_V", "cl_nm_per_V"});
        const ProbeSpec pd;
        s.probe.spring_N_per_m = r.num(pr, "probe", "spring_N_per_m", &pd.spring_N_per_m);
        s.probe.deflection_nm_per_V = r.num(pr, "probe", "deflection_nm_per_V", &pd.deflection_nm_per_V);
        s.probe.lateral_nN_per_V = r.num(pr, "probe", "lateral_nN_per_V", &pd.lateral_nN_per_V);
        s.probe.lever_length_um = r.num(pr, "probe", "lever_length_um", &pd.lever_length_um);
        s.probe.tip_height_um = r.num(pr, "probe", "tip_height_um", &pd.tip_height_um);
        s.probe.tip_radius_nm = r.num(pr, "probe", "tip_radius_nm", &pd.tip_radius_nm);
        s.probe.tip_half_angle_deg = r.num(pr, "probe", "tip_half_angle_deg", &pd.tip_half_angle_deg);
        s.probe.scan_angle_deg = r.num(pr, "probe", "scan_angle_deg", &pd.scan_angle_deg);
        // The real lever's displacement constants (the simulator's truth);
        // left out, the beam's 3 h K_n / (2 l).
        if (pr["cn_nm_per_V"].IsDefined() && !pr["cn_nm_per_V"].IsNull())
            s.probe.cn_nm_per_V = r.num(pr, "probe", "cn_nm_per_V", nullptr);
        if (pr["cl_nm_per_V"].IsDefined() && !pr["cl_nm_per_V"].IsNull())
            s.probe.cl_nm_per_V = r.num(pr, "probe", "cl_nm_per_V", nullptr);
    }
}

// firmware: the card's settings (the sweep's firmware knobs).
void read_firmware(const Reader &r, const YAML::Node &root, Scene &s)
{
    YAML::Node fw = root["firmware"];
    if (fw.IsDefined() && !fw.IsNull()) {
        // The ranges are the card's (fw_card_check): the launcher's --check
        // names the rule a value breaks; here only the types and signs.
        r.only_keys(fw, "firmware", {"adc_bits", "word_bits", "compensate", "disp_n_nm_per_V", "disp_l_nm_per_V", "lateral_nN_per_V", "mu",
                                     "drift_max_step_nm", "interlock", "interlock_normal_nN", "interlock_lateral_nN"});
        auto whole = [&](const char *k, int dflt) {   // a whole number (kSceneRanges)
            const double dv = dflt;
            return static_cast<int>(r.num(fw, "firmware", k, &dv));
        };
        s.adc_bits = whole("adc_bits", s.adc_bits);
        s.word_bits = whole("word_bits", s.word_bits);
        s.compensate = r.boolean(fw, "firmware", "compensate", s.compensate);
        // The lever's constants as calibrated (./afm calib ... --write): the
        // card's configuration; left out, the firmware's estimate (C) or the
        // probe's values (the lateral gain, the tip-substrate mu).
        auto optional = [&](const char *k, std::optional<double> *out) {
            if (fw[k].IsDefined() && !fw[k].IsNull()) *out = r.num(fw, "firmware", k, nullptr);
        };
        optional("disp_n_nm_per_V", &s.fw_cal.disp_n_nm_per_V);
        optional("disp_l_nm_per_V", &s.fw_cal.disp_l_nm_per_V);
        optional("lateral_nN_per_V", &s.fw_cal.lateral_nN_per_V);
        if (fw["mu"].IsDefined() && !fw["mu"].IsNull()) s.fw_cal.mu = r.num(fw, "firmware", "mu", nullptr);
        optional("drift_max_step_nm", &s.fw_cal.drift_max_step_nm);
        // The force interlock: positive limits here; below the channel's
        // full scale is the card's rule (fw_guard_check, named by the
        // launcher with the probe's keys).
        s.fw_cal.interlock = r.boolean(fw, "firmware", "interlock", s.fw_cal.interlock);
        optional("interlock_normal_nN", &s.fw_cal.interlock_normal_nN);
        optional("interlock_lateral_nN", &s.fw_cal.interlock_lateral_nN);
    }
}

// afm: the microscope's controller (the z servo's speed).
void read_afm(const Reader &r, const YAML::Node &root, Scene &s)
{
    YAML::Node a = root["afm"];
    if (!a.IsDefined() || a.IsNull()) return;
    r.only_keys(a, "afm", {"z_speed_nm_per_s"});
    const Scene d;
    s.z_speed_nm_per_s = r.num(a, "afm", "z_speed_nm_per_s", &d.z_speed_nm_per_s);
}

// objects.scatter: particles drawn at random, the bench's own generator
// (xorshift64*), so every process and machine draws the same ones.
// Listed objects, at most (scattered particles: objects.scatter.count <=
// 5000, the placement's O(count^2)); a 50 MB scene listing 923k particles
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
// host_bridge/pattern.hpp).
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

// operator.haptic, operator.hand: the device and the hand holding it.
void read_haptic(const Reader &r, const YAML::Node &op, Scene &s)
{
    const HapticSpec dh;
    YAML::Node h = op["haptic"];
    if (h.IsDefined() && !h.IsNull()) {
        const std::string k = "operator.haptic";
        r.only_keys(h, k, {"half_range_mm", "max_force_N", "max_stiffness_N_per_m", "force_gain_N_per_nN", "damping_Ns_per_m",
                           "passivity_check", "load_span_nN"});
        s.op.haptic.half_range_mm = r.num(h, k, "half_range_mm", &dh.half_range_mm);
        s.op.haptic.max_force_N = r.num(h, k, "max_force_N", &dh.max_force_N);
        s.op.haptic.max_stiffness_N_per_m = r.num(h, k, "max_stiffness_N_per_m", &dh.max_stiffness_N_per_m);
        const YAML::Node g = h["force_gain_N_per_nN"];
        if (g.IsDefined() && !g.IsNull() && !(g.IsScalar() && g.Scalar() == "auto"))
            s.op.haptic.force_gain_N_per_nN = r.num(h, k, "force_gain_N_per_nN", nullptr);
        s.op.haptic.damping_Ns_per_m = r.num(h, k, "damping_Ns_per_m", &dh.damping_Ns_per_m);
        s.op.haptic.passivity_check = r.boolean(h, k, "passivity_check", true);
        s.op.haptic.load_span_nN = r.num(h, k, "load_span_nN", &dh.load_span_nN);
    }
    const HandSpec dd;
    YAML::Node hand = op["hand"];
    if (hand.IsDefined() && !hand.IsNull()) {
        const std::string k = "operator.hand";
        r.only_keys(hand, k, {"stiffness_N_per_m", "damping_Ns_per_m", "mass_kg"});
        s.op.hand.stiffness_N_per_m = r.num(hand, k, "stiffness_N_per_m", &dd.stiffness_N_per_m);
        s.op.hand.damping_Ns_per_m = r.num(hand, k, "damping_Ns_per_m", &dd.damping_Ns_per_m);
        s.op.hand.mass_kg = r.num(hand, k, "mass_kg", &dd.mass_kg);
    }
}

// operator.plan.cuts: lines cut before the pushes (lithography), inside the
// joystick's reach, pressed above the threshold (else nothing is cut).
void read_plan_cuts(const Reader &r, const YAML::Node &n, Scene &s)
{
    if (!n.IsDefined() || n.IsNull()) return;
    const std::string k = "operator.plan.cuts";
    if (!n.IsSequence()) r.fail(k, "must be a list, got " + Reader::show(n));
    if (n.size() > 0 && !s.has_effect("lithography"))
        r.fail(k, "cutting needs the lithography effect (effects: [..., lithography])");
    const double reach = s.field_nm / 2;
    for (std::size_t i = 0; i < n.size(); ++i) {
        const std::string p = k + "[" + std::to_string(i) + "]";
        r.only_keys(n[i], p, {"from_nm", "to_nm", "load_nN"});
        CutSpec c;
        c.from_nm = r.vec2(n[i]["from_nm"], p + ".from_nm");
        c.to_nm = r.vec2(n[i]["to_nm"], p + ".to_nm");
        for (const auto &[end, v] : {std::pair{"from_nm", c.from_nm}, std::pair{"to_nm", c.to_nm}})
            if (std::fabs(v.x - s.field_center_nm.x) > reach || std::fabs(v.y - s.field_center_nm.y) > reach)
                r.fail(p + "." + end, "is outside the field, got " + Reader::show(n[i][end]));
        c.load_nN = r.num(n[i], p, "load_nN", nullptr);
        if (c.load_nN <= s.litho.threshold_nN)
            r.fail(p + ".load_nN", "must exceed sample.lithography.threshold_nN (" + std::to_string(s.litho.threshold_nN) +
                                       ") or nothing is cut, got " + Reader::show(n[i]["load_nN"]));
        s.op.plan.cuts.push_back(c);
    }
}

// operator.plan: the automatic planner's settings (its presence turns it
// on). With operator.mode: browser it only sets the strokes a person asks
// for on the page (tolerance, speeds, scans, pushes): the planner is not
// turned on, and cuts, which only the automatic planner makes, are refused.
void read_plan(const Reader &r, const YAML::Node &op, Scene &s)
{
    YAML::Node n = op["plan"];
    if (!n.IsDefined()) return;
    const std::string k = "operator.plan";
    PlanSpec &p = s.op.plan;
    const PlanSpec d;
    const bool browser = s.op.mode == "browser";
    p.enabled = !browser;
    if (n.IsNull()) return;
    if (browser && n.IsMap() && n["cuts"].IsDefined())
        r.fail(k + ".cuts", "the automatic planner's: with operator.mode: browser operator.plan sets only the page's strokes");
    r.only_keys(n, k, {"tolerance_nm", "speed_nm_per_s", "travel_speed_nm_per_s", "scan_size_nm", "scan_px", "scan_s",
                       "max_pushes", "clearance_nm", "push_depth_nm", "approach_nm", "wire_tolerance_nm", "wire_step_nm",
                       "cuts"});
    p.tolerance_nm = r.num(n, k, "tolerance_nm", &d.tolerance_nm);
    p.speed_nm_per_s = r.num(n, k, "speed_nm_per_s", &d.speed_nm_per_s);
    p.travel_speed_nm_per_s = r.num(n, k, "travel_speed_nm_per_s", &d.travel_speed_nm_per_s);
    p.scan_size_nm = r.num(n, k, "scan_size_nm", &d.scan_size_nm);
    const double px_d = d.scan_px, mp_d = d.max_pushes;
    const double px = r.num(n, k, "scan_px", &px_d);
    p.scan_px = static_cast<int>(px);
    p.scan_s = r.num(n, k, "scan_s", &d.scan_s);
    const double mp = r.num(n, k, "max_pushes", &mp_d);
    p.max_pushes = static_cast<int>(mp);
    p.clearance_nm = r.num(n, k, "clearance_nm", &d.clearance_nm);
    p.push_depth_nm = r.num(n, k, "push_depth_nm", &d.push_depth_nm);
    p.approach_nm = r.num(n, k, "approach_nm", &d.approach_nm);
    p.wire_tolerance_nm = r.num(n, k, "wire_tolerance_nm", &d.wire_tolerance_nm);
    p.wire_step_nm = r.num(n, k, "wire_step_nm", &d.wire_step_nm);
    read_plan_cuts(r, n["cuts"], s);
}

// What the planner needs and excludes, checked once the whole scene is read.
void check_plan(const Reader &r, const Scene &s)
{
    if (!s.op.plan.enabled) {
        if (s.targets.any()) r.fail("objects.targets", "targets are for the planner: give operator.plan as well");
        if (!s.wire_targets.empty()) r.fail("objects.wire_targets", "targets are for the planner: give operator.plan as well");
        const double most = std::max(s.op.load_nN, s.op.load_ramp_to_nN.value_or(0.0));
        if (s.op.haptic.load_span_nN > 0 && most > s.op.haptic.load_span_nN)
            r.fail("operator.haptic.load_span_nN", "the hand presses the stylus to at most its stop, " +
                                                       Reader::show(YAML::Node(s.op.haptic.load_span_nN)) +
                                                       " nN, but the script asks for " + Reader::show(YAML::Node(most)) + " nN");
        return;
    }
    if (!s.targets.any() && s.wire_targets.empty() && s.op.plan.cuts.empty())
        r.fail("operator.plan", "the planner needs objects.targets (particles), objects.wire_targets (rods) or operator.plan.cuts");
    if (!s.op.local_scans.empty())
        r.fail("operator.local_scans", "the planner takes its own local scans: drop operator.local_scans with operator.plan");
    if (!s.op.cantilever_changes.empty())
        r.fail("operator.cantilever_changes", "not supported with operator.plan");
    if (s.op.haptic.load_span_nN > 0)
        r.fail("operator.haptic.load_span_nN", "the planner sets the load itself: drop the stylus's z axis with operator.plan");
    if (s.op.mode != "script") r.fail("operator.mode", "the planner drives the hand: drop operator.mode with operator.plan");
}

// operator: the scripted hand (path, load, local scans, lever changes), the
// haptic device and hand, and the planner.
void read_operator(const Reader &r, const YAML::Node &root, Scene &s)
{
    const Scene d;  // defaults
    YAML::Node op = root["operator"];
    if (!op.IsDefined()) r.fail("operator", "required value is missing");
    r.only_keys(op, "operator", {"load_nN", "speed_nm_per_s", "path_nm", "kappa", "local_scans", "cantilever_changes", "mode",
                                 "feel_threshold_N", "haptic", "hand", "plan", "scan_load_nN", "load_ramp_to_nN"});
    s.op.load_nN = r.num(op, "operator", "load_nN", &d.op.load_nN);
    if (op["load_ramp_to_nN"].IsDefined() && !op["load_ramp_to_nN"].IsNull())
        s.op.load_ramp_to_nN = r.num(op, "operator", "load_ramp_to_nN", nullptr);
    if (op["scan_load_nN"].IsDefined() && !op["scan_load_nN"].IsNull())
        s.op.scan_load_nN = r.num(op, "operator", "scan_load_nN", nullptr);
    s.op.speed_nm_per_s = r.num(op, "operator", "speed_nm_per_s", &d.op.speed_nm_per_s);
    s.op.kappa = r.num(op, "operator", "kappa", &d.op.kappa);
    s.op.mode = r.str(op, "operator", "mode", &d.op.mode, {"script", "feel", "browser"});
    if (s.op.mode == "browser" && s.time_mode != "realtime")
        r.fail("operator.mode", "browser: a person's hand is paced by the wall clock: give time_mode: realtime");
    s.op.feel_threshold_N = r.num(op, "operator", "feel_threshold_N", &d.op.feel_threshold_N);
    read_haptic(r, op, s);
    read_plan(r, op, s);
    YAML::Node path_n = op["path_nm"];
    if (!path_n.IsDefined() || path_n.IsNull()) {
        if (!s.op.plan.enabled) r.fail("operator.path_nm", "required value is missing");
        path_n = YAML::Node(YAML::NodeType::Sequence);
        YAML::Node c(YAML::NodeType::Sequence);
        c.push_back(s.field_center_nm.x);
        c.push_back(s.field_center_nm.y);
        path_n.push_back(c);
    }
    if (!path_n.IsSequence() || path_n.size() < 1)
        r.fail("operator.path_nm", "must be a list of [x, y] waypoints, got " + Reader::show(path_n));
    const double reach = s.op.kappa * s.field_nm / 2;
    for (std::size_t i = 0; i < path_n.size(); ++i) {
        const std::string key = "operator.path_nm[" + std::to_string(i) + "]";
        Vec2 v = r.vec2(path_n[i], key);
        if (std::fabs(v.x - s.field_center_nm.x) > reach || std::fabs(v.y - s.field_center_nm.y) > reach)
            r.fail(key, "waypoint " + Reader::show(path_n[i]) + " is outside the joystick's reach (kappa * field_nm / 2 around the field centre)");
        s.op.path_nm.push_back(v);
    }
    YAML::Node ls_n = op["local_scans"];
    if (ls_n.IsDefined() && !ls_n.IsNull()) {
        if (!ls_n.IsSequence()) r.fail("operator.local_scans", "must be a list, got " + Reader::show(ls_n));
        for (std::size_t i = 0; i < ls_n.size(); ++i) {
            const std::string key = "operator.local_scans[" + std::to_string(i) + "]";
            r.only_keys(ls_n[i], key, {"at_s", "around_id", "size_nm"});
            LocalScanSpec ls;
            ls.at_s = r.num(ls_n[i], key, "at_s", nullptr);
            const double id = r.num(ls_n[i], key, "around_id", nullptr);
            ls.around_id = static_cast<int>(id);
            bool known = false;
            for (const auto &p : s.particles) known = known || p.id == ls.around_id;
            for (const auto &m : s.landmarks) known = known || m.id == ls.around_id;
            if (!known) r.fail(key + ".around_id", "names no particle or landmark of objects, got " + Reader::show(ls_n[i]["around_id"]));
            const double size_d = 400;
            ls.size_nm = r.num(ls_n[i], key, "size_nm", &size_d);
            if (!s.op.local_scans.empty() && ls.at_s < s.op.local_scans.back().at_s)
                r.fail(key + ".at_s", "local scans must be in time order, got " + Reader::show(ls_n[i]["at_s"]));
            s.op.local_scans.push_back(ls);
        }
    }
    YAML::Node cc_n = op["cantilever_changes"];
    if (cc_n.IsDefined() && !cc_n.IsNull()) {
        if (!cc_n.IsSequence()) r.fail("operator.cantilever_changes", "must be a list, got " + Reader::show(cc_n));
        for (std::size_t i = 0; i < cc_n.size(); ++i) {
            const std::string key = "operator.cantilever_changes[" + std::to_string(i) + "]";
            r.only_keys(cc_n[i], key, {"at_s", "offset_nm"});
            CantileverChangeSpec cc;
            cc.at_s = r.num(cc_n[i], key, "at_s", nullptr);
            if (!cc_n[i]["offset_nm"].IsDefined()) r.fail(key + ".offset_nm", "required value is missing");
            cc.offset_nm = r.vec2(cc_n[i]["offset_nm"], key + ".offset_nm");
            if (!s.op.cantilever_changes.empty() && cc.at_s < s.op.cantilever_changes.back().at_s)
                r.fail(key + ".at_s", "cantilever changes must be in time order, got " + Reader::show(cc_n[i]["at_s"]));
            s.op.cantilever_changes.push_back(cc);
        }
    }
}

// outputs: the display and the files a run writes.
void read_outputs(const Reader &r, const YAML::Node &root, Scene &s)
{
    YAML::Node out = root["outputs"];
    if (out.IsDefined() && !out.IsNull()) {
        r.only_keys(out, "outputs", {"image_px", "video", "png", "trails", "contact_sheet_frames", "update_mode"});
        const double px_d = s.out.image_px;
        const double px = r.num(out, "outputs", "image_px", &px_d);
        s.out.image_px = static_cast<int>(px);
        const std::string mp4 = "mp4";
        s.out.video = r.str(out, "outputs", "video", &mp4, {"mp4", "avi", "none"});
        s.out.png = r.boolean(out, "outputs", "png", true);
        s.out.trails = r.boolean(out, "outputs", "trails", false);
        const double csf = 16;
        const double sheet = r.num(out, "outputs", "contact_sheet_frames", &csf);
        s.out.contact_sheet_frames = static_cast<int>(sheet);
        const std::string local = "local";
        s.out.update_mode = r.str(out, "outputs", "update_mode", &local, {"local", "full"});
    }
}

}  // namespace

namespace {

// A scene file, or a file it includes, is at most this large (a scene of
// thousands of listed objects is well under it).
constexpr long long kMaxSceneBytes = 4 << 20;

// Refuses, by its type and before any read, what is not a regular file (a
// directory aborted the reader; a FIFO hung it), and a file over the cap.
void check_scene_file(const std::string &path, const std::string &what)
{
    struct stat st {};
    if (stat(path.c_str(), &st) != 0) throw SceneError(afm::printable(path) + ": cannot open " + what + " (no such file or not readable)");
    if (!S_ISREG(st.st_mode)) {
        const char *kind = S_ISDIR(st.st_mode) ? "a directory" : S_ISFIFO(st.st_mode) ? "a FIFO"
                           : S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode) ? "a device" : S_ISSOCK(st.st_mode) ? "a socket" : "not a regular file";
        throw SceneError(afm::printable(path) + ": cannot read " + what + ": it is " + kind + ", not a file");
    }
    if (st.st_size > kMaxSceneBytes)
        throw SceneError(afm::printable(path) + ": " + what + " of " + std::to_string(static_cast<long long>(st.st_size)) +
                         " bytes is larger than a scene may be (" + std::to_string(kMaxSceneBytes) + " bytes)");
}

YAML::Node load_yaml(const std::string &path, const std::string &what)
{
    check_scene_file(path, what);
    {
        std::ifstream probe(path);
        if (!probe) throw SceneError(afm::printable(path) + ": cannot open " + what + " (no such file or not readable)");
    }
    YAML::Node n;
    try {
        n = YAML::LoadFile(path);
    } catch (const YAML::ParserException &e) {
        throw SceneError(afm::printable(path) + ": YAML syntax error at line " + std::to_string(e.mark.line + 1) + ": " + afm::printable(e.msg));
    }
    if (!n.IsDefined() || n.IsNull()) throw SceneError(afm::printable(path) + ": the " + what + " is empty");
    return n;
}

std::string dir_of(const std::string &path)
{
    const auto slash = path.find_last_of('/');
    return slash == std::string::npos ? std::string(".") : path.substr(0, slash);
}

// Copies what `from` has and `into` lacks, recursively through mappings
// (the including file's own values win).
void merge_missing(YAML::Node into, const YAML::Node &from)
{
    for (auto it = from.begin(); it != from.end(); ++it) {
        const std::string k = it->first.as<std::string>();
        if (!into[k].IsDefined() || into[k].IsNull()) {
            into[k] = YAML::Clone(it->second);
            t_included.push_back(into[k]);
        }
        else if (into[k].IsMap() && it->second.IsMap()) merge_missing(into[k], it->second);
    }
}

// The scene's YAML with its includes merged in (include: FILE or [FILE,
// ...], relative to the scene; each may hold probe, firmware and sample
// only: a lever's calibration, ./afm calib ... --write), and a PNG
// target's path made absolute, so the tree stands alone.
// The keys a scene may have at its top level.
const std::set<std::string> kTopLevelKeys = {"name", "seed", "duration_s", "sample_rate_hz", "block_hz", "frame_rate_hz",
                                             "time_mode", "effects", "sample", "probe", "firmware", "objects", "operator",
                                             "outputs", "include", "afm", "expect"};

// An included file holds probe, firmware and sample only. Its refusals
// name the file and the line but never quote it: an include may name a
// file the scene's author could not read (include: /etc/shadow printed
// root's hash as the value that was not a mapping).
void check_include_keys(const std::string &fp, const YAML::Node &part)
{
    const std::string file = afm::printable(fp);
    if (!part.IsMap())
        throw SceneError(file + ": an included file must be a mapping of probe, firmware and sample (not quoted here: it is "
                                "an included file)");
    std::set<std::string> seen;
    for (auto it = part.begin(); it != part.end(); ++it) {
        const std::string line = std::to_string(it->first.Mark().line + 1);
        const bool known = it->first.IsScalar() && (it->first.Scalar() == "probe" || it->first.Scalar() == "firmware" ||
                                                    it->first.Scalar() == "sample");
        if (!known)
            throw SceneError(file + ": line " + line + ": a key other than probe, firmware or sample (not quoted here: it is "
                                    "an included file)");
        if (!seen.insert(it->first.Scalar()).second) throw SceneError(file + ": line " + line + ": " + it->first.Scalar() + " given twice");
    }
}

YAML::Node resolved_yaml(const std::string &path)
{
    t_included.clear();
    YAML::Node root = load_yaml(path, "scene file");
    const Reader r(path);
    // before the includes are merged (and the include key removed): a key
    // given twice, or one that is not a name, is refused as the scene has it
    r.only_keys(root, "", kTopLevelKeys);
    YAML::Node inc = root["include"];
    if (inc.IsDefined() && !inc.IsNull()) {
        std::vector<std::string> files;
        if (inc.IsScalar()) files.push_back(inc.Scalar());
        else if (inc.IsSequence())
            for (const auto &f : inc) {
                if (!f.IsScalar()) r.fail("include", "must be a file name or a list of them, got " + Reader::show(inc));
                files.push_back(f.Scalar());
            }
        else r.fail("include", "must be a file name or a list of them, got " + Reader::show(inc));
        for (const std::string &f : files) {
            const std::string fp = f.empty() || f[0] == '/' ? f : dir_of(path) + "/" + f;
            const YAML::Node part = load_yaml(fp, "included file (include: of " + afm::printable(path) + ")");
            check_include_keys(fp, part);
            try {
                merge_missing(root, part);
            } catch (const YAML::Exception &e) {   // a nested key that is not a name
                Reader(fp).fail("(included)", std::string("cannot merge: ") + e.what());
            }
        }
        root.remove("include");
    }
    // sample.substrate.gsf, like the includes, relative to the scene
    const YAML::Node sample = root["sample"];
    if (sample.IsDefined() && sample.IsMap() && sample["substrate"].IsDefined() && sample["substrate"].IsMap()) {
        YAML::Node sub = root["sample"]["substrate"];
        const YAML::Node gsf = sub["gsf"];
        if (gsf.IsDefined() && gsf.IsScalar() && !gsf.Scalar().empty() && gsf.Scalar()[0] != '/')
            sub["gsf"] = dir_of(path) + "/" + gsf.Scalar();
    }
    // (Indexing a node by a key turns a sequence into a mapping: look first.)
    const YAML::Node objects = root["objects"];
    if (objects.IsDefined() && objects.IsMap() && objects["targets"].IsDefined() && objects["targets"].IsMap()) {
        YAML::Node targets = root["objects"]["targets"];
        const YAML::Node png = targets["png"];
        if (png.IsDefined() && png.IsScalar() && !png.Scalar().empty() && png.Scalar()[0] != '/')
            targets["png"] = dir_of(path) + "/" + png.Scalar();
    }
    return root;
}

}  // namespace

std::string resolved_scene_text(const std::string &path)
{
    const YAML::Node root = resolved_yaml(path);
    YAML::Emitter e;
    e << root;
    return "# The scene this run ran: " + path + ", its includes merged in.\n" + std::string(e.c_str()) + "\n";
}

double point_segment_distance(Vec2 p, Vec2 a, Vec2 b)
{
    const double dx = b.x - a.x, dy = b.y - a.y, l2 = dx * dx + dy * dy;
    const double t = l2 > 0 ? std::clamp(((p.x - a.x) * dx + (p.y - a.y) * dy) / l2, 0.0, 1.0) : 0.0;
    return std::hypot(p.x - a.x - t * dx, p.y - a.y - t * dy);
}

namespace {

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

// Two bodies cannot start in one place: particles that overlap or coincide,
// a particle on a wire or a landmark, wires that touch or cross. The
// scattered particles keep their gaps by construction; listed ones are
// checked here, pairwise (at most kMaxListedParticles of them).
void check_overlaps(const Reader &r, const Scene &s)
{
    auto fmt = [](double v) { char b[32]; std::snprintf(b, sizeof b, "%.1f", v); return std::string(b); };
    for (std::size_t i = 0; i < s.particles.size(); ++i) {
        const ParticleSpec &p = s.particles[i];
        for (std::size_t j = 0; j < i; ++j) {
            const ParticleSpec &q = s.particles[j];
            const double d = std::hypot(p.x_nm - q.x_nm, p.y_nm - q.y_nm);
            if (d < p.radius_nm + q.radius_nm - 1e-9)
                r.fail(particle_key(s, i), "overlaps " + particle_key(s, j) + " (id " + std::to_string(q.id) + "): centres " + fmt(d) +
                                               " nm apart, radii " + fmt(p.radius_nm) + " + " + fmt(q.radius_nm) + " nm");
        }
        for (std::size_t k = 0; k < s.wires.size(); ++k) {
            const WireSpec &w = s.wires[k];
            const Vec2 c{p.x_nm, p.y_nm};
            const double d = segment_gap(c, c, {w.x0_nm, w.y0_nm}, {w.x1_nm, w.y1_nm});
            if (d < p.radius_nm + w.diameter_nm / 2 - 1e-9)
                r.fail(particle_key(s, i), "lies on objects.wires[" + std::to_string(k) + "] (id " + std::to_string(w.id) + "): " + fmt(d) +
                                               " nm from its axis, closer than " + fmt(p.radius_nm + w.diameter_nm / 2) + " nm");
        }
        for (std::size_t k = 0; k < s.landmarks.size(); ++k) {
            const LandmarkSpec &m = s.landmarks[k];
            const double dx = std::max(0.0, std::fabs(p.x_nm - m.x_nm) - m.side_nm / 2), dy = std::max(0.0, std::fabs(p.y_nm - m.y_nm) - m.side_nm / 2);
            if (std::hypot(dx, dy) < p.radius_nm - 1e-9)
                r.fail(particle_key(s, i), "lies on objects.landmarks[" + std::to_string(k) + "] (id " + std::to_string(m.id) + ")");
        }
    }
    for (std::size_t i = 0; i < s.wires.size(); ++i)
        for (std::size_t j = 0; j < i; ++j) {
            const WireSpec &a = s.wires[i], &b = s.wires[j];
            const double d = segment_gap({a.x0_nm, a.y0_nm}, {a.x1_nm, a.y1_nm}, {b.x0_nm, b.y0_nm}, {b.x1_nm, b.y1_nm});
            if (d < (a.diameter_nm + b.diameter_nm) / 2 - 1e-9)
                r.fail("objects.wires[" + std::to_string(i) + "]", "touches or crosses objects.wires[" + std::to_string(j) + "] (id " +
                                                                   std::to_string(b.id) + "): axes " + fmt(d) + " nm apart");
        }
}

// A path that starts with the apex inside a particle or a wire: the
// simulator would throw the object clear in the first sample (tens of nm,
// unasked). Refused, naming the start and the object; touching is allowed.
// Only when the run starts engaged (a planned run starts lifted).
void check_path_start(const Reader &r, const Scene &s)
{
    if (!s.start_engaged() || s.op.path_nm.empty()) return;
    auto fmt = [](double v) { char b[32]; std::snprintf(b, sizeof b, "%.1f", v); return std::string(b); };
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

// expect: the checks of the run's verdict this scene fails on purpose.
void read_expect(const Reader &r, const YAML::Node &root, Scene &s)
{
    const YAML::Node e = root["expect"];
    if (!e.IsDefined() || e.IsNull()) return;
    if (!e.IsSequence()) r.fail("expect", "must be a list of the run's checks, got " + Reader::show(e));
    const auto &known = verdict_checks();
    for (std::size_t i = 0; i < e.size(); ++i) {
        const std::string k = "expect[" + std::to_string(i) + "]";
        if (!e[i].IsScalar() || std::find(known.begin(), known.end(), e[i].Scalar()) == known.end()) {
            std::string list;
            for (const auto &n : known) list += (list.empty() ? "" : ", ") + n;
            r.fail(k, "unknown check " + Reader::show(e[i]) + " (known: " + list + ")");
        }
        if (std::find(s.expect.begin(), s.expect.end(), e[i].Scalar()) != s.expect.end())
            r.fail(k, "check " + Reader::show(e[i]) + " is listed twice");
        s.expect.push_back(e[i].Scalar());
    }
}

}  // namespace

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

int64_t frame_utime(const Scene &s, int k) { return std::llround(k * 1e6 / s.frame_rate_hz); }

int64_t block_end_utime(const Scene &s, int64_t n) { return std::llround((n + 1) * 1e6 / s.block_hz); }

int frames_due(const Scene &s, int64_t t_us)
{
    int k = static_cast<int>(std::floor(t_us * 1e-6 * s.frame_rate_hz)) + 1;
    while (k > 0 && frame_utime(s, k - 1) > t_us) --k;
    while (frame_utime(s, k) <= t_us) ++k;
    return std::min(k, s.total_frames());
}

int local_scan_frame(const Scene &s, int i)
{
    const int64_t at_us = std::llround(s.op.local_scans.at(static_cast<std::size_t>(i)).at_s * 1e6);
    // at_s is within [0, duration_s] (load_scene), so k stays near total_frames()
    int k = std::max(0, static_cast<int>(std::floor(at_us * 1e-6 * s.frame_rate_hz)) - 1);
    while (frame_utime(s, k) < at_us) ++k;
    return k;
}

int frames_to_wait_for(const Scene &s, int64_t n, int64_t blocks)
{
    const int due = frames_due(s, block_end_utime(s, n));
    if (n + 1 >= blocks) return due;
    int need = std::max(0, due - kRendererWindowFrames);
    // the renderer's last frame, at the end of the run as it knows it (sim_afm's "ending")
    const int last = frames_due(s, block_end_utime(s, blocks - 1)) - 1;
    if (last < due) need = std::max(need, last + 1);
    for (int i = 0; i < static_cast<int>(s.op.local_scans.size()); ++i) {
        const int f = local_scan_frame(s, i);
        if (f >= due) break;   // in time order (load_scene)
        need = std::max(need, f + 1);
    }
    return need;
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
