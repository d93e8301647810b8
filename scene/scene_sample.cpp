// The scene's effects, sample, probe, firmware and afm sections
// (scene_reader.hpp).
#include "scene_reader.hpp"

extern "C" {
#include "fw_hyst.h"   // FW_HYST_N_MAX: the card's largest model
}

namespace afm::scene_detail {



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
// firmware.calibration: a bench calibration's id and what it measured
// (analysis/card_calib.py writes it into an include).
static void read_bench_calibration(const Reader &r, const YAML::Node &n, Scene &s)
{
    if (!n.IsDefined() || n.IsNull()) return;
    const std::string k = "firmware.calibration";
    r.only_keys(n, k, {"run", "mu", "lateral_nN_per_V", "disp_n_nm_per_V"});
    FirmwareCalibration::Bench b;
    b.run = r.str(n, k, "run", nullptr);
    for (const auto &[key, out] : {std::pair{"mu", &b.mu}, {"lateral_nN_per_V", &b.lateral_nN_per_V}, {"disp_n_nm_per_V", &b.disp_n_nm_per_V}})
        if (n[key].IsDefined() && !n[key].IsNull()) *out = r.num(n, k, key, nullptr);
    s.fw_cal.calibration = b;
}

// One axis of firmware.scanner: {r_nm: [...], w: [...]}, in the domain
// fw_hyst_check holds the card's model to (fw_hyst.h): 1 to 16 plays, the
// thresholds from 0 strictly increasing, every partial sum of the weights
// in [1/2, 2]; each refusal names the key and its value.
// The list items' ranges (a threshold within fw_hyst.h's largest half
// range, 2^28 pm; a weight within +-2), held here as their partial sums
// and order are: the lists' own rules, not kSceneRanges' single numbers.
constexpr SceneRange kR = scene_rows::in("firmware.scanner.AXIS.r_nm[]", 0, 268435.456, "nm");
constexpr SceneRange kW = scene_rows::in("firmware.scanner.AXIS.w[]", -2, 2, "");

static FirmwareCalibration::ScannerAxis read_scanner_axis(const Reader &r, const YAML::Node &n, const std::string &k)
{
    if (!n.IsDefined() || n.IsNull()) r.fail(k, "required in firmware.scanner (./afm calib scanner --write writes it)");
    r.only_keys(n, k, {"r_nm", "w"});
    FirmwareCalibration::ScannerAxis a;
    for (const auto &[key, out] : {std::pair{"r_nm", &a.r_nm}, {"w", &a.w}}) {
        const YAML::Node l = n[key];
        const std::string lk = k + "." + key;
        if (!l.IsSequence() || l.size() < 1 || l.size() > FW_HYST_N_MAX)
            r.fail(lk, "must be a list of 1 to " + std::to_string(FW_HYST_N_MAX) + " numbers (one per play), got " + Reader::show(l));
        for (std::size_t i = 0; i < l.size(); ++i)
            out->push_back(r.check_num(l[i], lk + "[" + std::to_string(i) + "]", key == std::string("r_nm") ? kR : kW));
    }
    if (a.w.size() != a.r_nm.size())
        r.fail(k + ".w", "must have one weight per threshold (" + std::to_string(a.r_nm.size()) + "), got " + std::to_string(a.w.size()));
    if (a.r_nm[0] != 0) r.fail(k + ".r_nm[0]", "must be 0 (the identity play), got " + Reader::show(n["r_nm"][0]));
    double sum = 0;
    for (std::size_t i = 0; i < a.w.size(); ++i) {
        const std::string at = "[" + std::to_string(i) + "]";
        if (i > 0 && !(a.r_nm[i] > a.r_nm[i - 1]))
            r.fail(k + ".r_nm" + at, "must be above the threshold before it (" + Reader::show(n["r_nm"][i - 1]) + "), got " + Reader::show(n["r_nm"][i]));
        sum += a.w[i];
        if (sum < 0.5 || sum > 2)
            r.fail(k + ".w" + at, "the weights' partial sum to here must lie in [0.5, 2] (the card's model must be invertible: fw_hyst.h), got " +
                                    std::to_string(sum) + " with this weight " + Reader::show(n["w"][i]));
    }
    return a;
}

// firmware.scanner: ./afm calib scanner's fit, {run, x, y}.
static void read_scanner(const Reader &r, const YAML::Node &n, Scene &s)
{
    if (!n.IsDefined() || n.IsNull()) return;
    const std::string k = "firmware.scanner";
    r.only_keys(n, k, {"run", "x", "y"});
    FirmwareCalibration::Scanner sc;
    sc.run = r.str(n, k, "run", nullptr);
    sc.axis[0] = read_scanner_axis(r, n["x"], k + ".x");
    sc.axis[1] = read_scanner_axis(r, n["y"], k + ".y");
    s.fw_cal.scanner = sc;
}

// firmware.hyst_enable, creep_enable and the creep law's keys.
static void read_scanner_compensation(const Reader &r, const YAML::Node &fw, Scene &s)
{
    FirmwareCalibration &c = s.fw_cal;
    c.hyst_enable = r.boolean(fw, "firmware", "hyst_enable", c.hyst_enable);
    c.creep_enable = r.boolean(fw, "firmware", "creep_enable", c.creep_enable);
    for (const auto &[k, out] : {std::pair{"creep_gamma_pct_per_decade", &c.creep_gamma_pct_per_decade}, {"creep_t0_s", &c.creep_t0_s}})
        if (fw[k].IsDefined() && !fw[k].IsNull()) *out = r.num(fw, "firmware", k, nullptr);
    read_scanner(r, fw["scanner"], s);
    if (c.hyst_enable && !c.scanner)
        r.fail("firmware.hyst_enable", "true needs the scanner's model, firmware.scanner (./afm calib scanner SCENE --write FILE, then include FILE), got none");
}

void read_firmware(const Reader &r, const YAML::Node &root, Scene &s)
{
    YAML::Node fw = root["firmware"];
    if (fw.IsDefined() && !fw.IsNull()) {
        // The ranges are the card's (fw_card_check): the launcher's --check
        // names the rule a value breaks; here only the types and signs.
        r.only_keys(fw, "firmware", {"adc_bits", "word_bits", "compensate", "disp_n_nm_per_V", "disp_l_nm_per_V", "lateral_nN_per_V", "mu",
                                     "drift_max_step_nm", "interlock", "interlock_normal_nN", "interlock_lateral_nN",
                                     "spring_N_per_m", "deflection_nm_per_V", "lever_length_um", "tip_height_um", "tip_radius_nm",
                                     "tip_half_angle_deg", "adhesion_nN", "particle_mu", "particle_adhesion_nN",
                                     "particle_shear_strength_MPa", "particle_contact_area_nm2", "wire_friction_nN_per_um", "wire_mu",
                                     "litho_threshold_nN", "litho_depth_nm_per_nN", "calibration", "hyst_enable", "creep_enable",
                                     "creep_gamma_pct_per_decade", "creep_t0_s", "scanner", "drift_filter",
                                     "drift_walk_nm_per_sqrt_min", "drift_rate_nm_per_min", "drift_scan_sigma_nm"});
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
        const std::string step = s.fw_cal.drift_filter;
        s.fw_cal.drift_filter = r.str(fw, "firmware", "drift_filter", &step, {"step", "kalman"});
        optional("drift_walk_nm_per_sqrt_min", &s.fw_cal.drift_walk_nm_per_sqrt_min);
        optional("drift_rate_nm_per_min", &s.fw_cal.drift_rate_nm_per_min);
        optional("drift_scan_sigma_nm", &s.fw_cal.drift_scan_sigma_nm);
        // The force interlock: positive limits here; below the channel's
        // full scale is the card's rule (fw_guard_check, named by the
        // launcher with the probe's keys).
        s.fw_cal.interlock = r.boolean(fw, "firmware", "interlock", s.fw_cal.interlock);
        optional("interlock_normal_nN", &s.fw_cal.interlock_normal_nN);
        optional("interlock_lateral_nN", &s.fw_cal.interlock_lateral_nN);
        FirmwareCalibration &c = s.fw_cal;
        for (const auto &[k, out] : {std::pair{"spring_N_per_m", &c.spring_N_per_m}, {"deflection_nm_per_V", &c.deflection_nm_per_V},
                                     {"lever_length_um", &c.lever_length_um}, {"tip_height_um", &c.tip_height_um},
                                     {"tip_radius_nm", &c.tip_radius_nm}, {"tip_half_angle_deg", &c.tip_half_angle_deg},
                                     {"adhesion_nN", &c.adhesion_nN}, {"particle_mu", &c.particle_mu},
                                     {"particle_adhesion_nN", &c.particle_adhesion_nN},
                                     {"particle_shear_strength_MPa", &c.particle_shear_strength_MPa},
                                     {"particle_contact_area_nm2", &c.particle_contact_area_nm2},
                                     {"wire_friction_nN_per_um", &c.wire_friction_nN_per_um}, {"wire_mu", &c.wire_mu},
                                     {"litho_threshold_nN", &c.litho_threshold_nN}, {"litho_depth_nm_per_nN", &c.litho_depth_nm_per_nN}})
            optional(k, out);
        read_bench_calibration(r, fw["calibration"], s);
        read_scanner_compensation(r, fw, s);
    }
}

namespace {

// afm.hysteresis, afm.creep, afm.scan_artefacts, afm.z_drift: the
// instrument's errors (InstrumentSpec).
void read_instrument(const Reader &r, const YAML::Node &a, Scene &s)
{
    const InstrumentSpec d;
    InstrumentSpec &i = s.instrument;
    // whether the mapping afm.NAME is given (its keys checked)
    auto given = [&](const YAML::Node &n, const char *name, std::set<std::string> keys) {
        if (!n.IsDefined() || n.IsNull()) return false;
        r.only_keys(n, std::string("afm.") + name, std::move(keys));
        return true;
    };
    const YAML::Node h = a["hysteresis"], c = a["creep"], sa = a["scan_artefacts"], z = a["z_drift"];
    if (given(h, "hysteresis", {"width_pct", "span_nm"})) {
        i.hysteresis_width_pct = r.num(h, "afm.hysteresis", "width_pct", &d.hysteresis_width_pct);
        i.hysteresis_span_nm = r.num(h, "afm.hysteresis", "span_nm", &d.hysteresis_span_nm);
    }
    if (given(c, "creep", {"gamma_pct_per_decade", "t0_s"})) {
        i.creep_pct_per_decade = r.num(c, "afm.creep", "gamma_pct_per_decade", &d.creep_pct_per_decade);
        i.creep_t0_s = r.num(c, "afm.creep", "t0_s", &d.creep_t0_s);
    }
    if (given(sa, "scan_artefacts", {"line_offset_rms_nm", "servo_lag_nm", "bow_sag_nm"})) {
        i.line_offset_rms_nm = r.num(sa, "afm.scan_artefacts", "line_offset_rms_nm", &d.line_offset_rms_nm);
        i.servo_lag_nm = r.num(sa, "afm.scan_artefacts", "servo_lag_nm", &d.servo_lag_nm);
        i.bow_sag_nm = r.num(sa, "afm.scan_artefacts", "bow_sag_nm", &d.bow_sag_nm);
    }
    if (given(z, "z_drift", {"rate_nm_per_min", "walk_nm_per_sqrt_min"})) {
        i.z_drift_nm_per_min = r.num(z, "afm.z_drift", "rate_nm_per_min", &d.z_drift_nm_per_min);
        i.z_drift_walk_nm_per_sqrt_min = r.num(z, "afm.z_drift", "walk_nm_per_sqrt_min", &d.z_drift_walk_nm_per_sqrt_min);
    }
}

}  // namespace

// afm: the microscope's controller (the z servo's speed) and its errors.
void read_afm(const Reader &r, const YAML::Node &root, Scene &s)
{
    YAML::Node a = root["afm"];
    if (!a.IsDefined() || a.IsNull()) return;
    r.only_keys(a, "afm", {"z_speed_nm_per_s", "hysteresis", "creep", "scan_artefacts", "z_drift"});
    const Scene d;
    s.z_speed_nm_per_s = r.num(a, "afm", "z_speed_nm_per_s", &d.z_speed_nm_per_s);
    read_instrument(r, a, s);
}

}  // namespace afm::scene_detail
