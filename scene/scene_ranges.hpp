// The range of every number a scene gives: one table, kSceneRanges, the one
// place load_scene (scene.cpp) takes a number's bounds from.
// tests/host/test_scene_ranges.cpp tries each row at both ends, just past
// them and with NaN and infinities, and checks that docs/scenes.md's section
// "Ranges" shows this table.
//
// A row's key is written as a user writes it, its dotted path from the
// scene's top level: a list's items are `[]` (objects.particles[].radius_nm),
// a pair's or a tuple's positions `[0]`, `[1]`, ... (sample.field_center_nm[0],
// operator.path_nm[][1]). Some bounds are other values of the scene, read
// before: the field (f = sample.field_nm about its centre (cx, cy) =
// sample.field_center_nm) and duration_s.
//
// The reader asks scene_range for the row of each number it reads, by the
// key its error messages name; a key without a row is a programming error
// (std::logic_error), never a default range.
#pragma once

#include "scene.hpp"

#include <string>

namespace afm {

// What a bound is: a number, or a value of the scene.
enum class SceneRef {
    kNumber,
    kField,          // f
    kFieldHalfNeg,   // -f/2
    kFieldHalf,      // f/2
    kFieldXLo,       // cx - f/2, the field's left edge
    kFieldXHi,       // cx + f/2
    kFieldYLo,       // cy - f/2
    kFieldYHi,       // cy + f/2
    kDuration,       // duration_s
};

struct SceneBound {
    SceneRef ref;
    double number;   // the bound when ref is kNumber
    constexpr SceneBound(double v) : ref(SceneRef::kNumber), number(v) {}   // NOLINT: a number is a bound
    constexpr SceneBound(SceneRef r) : ref(r), number(0) {}                 // NOLINT: so is a value of the scene
};

struct SceneRange {
    const char *key;
    SceneBound lo, hi;
    bool lo_open, hi_open;   // the end itself is refused
    const char *whole;       // nullptr: any number; else what it must be, "an integer", ...
    const char *unit;        // "" for a count or a pure number
    // nullptr, or where the value (with its pair) must also lie, a check of
    // its own after this range, whose message names the pair ("the field":
    // "... is outside the field")
    const char *inside;
};

namespace scene_rows {
// [lo, hi]
constexpr SceneRange in(const char *key, SceneBound lo, SceneBound hi, const char *unit)
{
    return {key, lo, hi, false, false, nullptr, unit, nullptr};
}
// (lo, hi]
constexpr SceneRange above(const char *key, SceneBound lo, SceneBound hi, const char *unit)
{
    return {key, lo, hi, true, false, nullptr, unit, nullptr};
}
// [lo, hi], a whole number
constexpr SceneRange whole(const char *key, double lo, double hi, const char *unit = "", const char *what = "an integer")
{
    return {key, lo, hi, false, false, what, unit, nullptr};
}
// [lo, hi], and inside `where` as a pair (its own check)
constexpr SceneRange pair_in(const char *key, double lo, double hi, const char *where)
{
    return {key, lo, hi, false, false, nullptr, "nm", where};
}
constexpr double kSeedMax = 9.007199254740992e15;   // 2^53: every seed a double holds exactly
}  // namespace scene_rows

// Keys in the order the reader reads them.
inline constexpr SceneRange kSceneRanges[] = {
    scene_rows::whole("seed", 0, scene_rows::kSeedMax, "", "a non-negative integer"),
    scene_rows::above("duration_s", 0, 3600, "s"),
    scene_rows::above("sample_rate_hz", 0, 1e7, "Hz"),
    scene_rows::above("block_hz", 0, 1e5, "Hz"),
    // the renderer's and the video writer's range (1e-300 passed and crashed the writer on an OpenCV assertion)
    scene_rows::in("frame_rate_hz", 0.1, 1000, "Hz"),
    scene_rows::above("sample.slope_deg", 0, 45, "deg"),
    scene_rows::in("sample.wire.adhesion_nN_per_um", 0, 1e5, "nN/um"),
    scene_rows::in("sample.wire.shear_strength_MPa", 0, 1e4, "MPa"),
    scene_rows::above("sample.wire.friction_nN_per_um", 0, 1e4, "nN/um"),
    scene_rows::above("sample.wire.youngs_modulus_GPa", 0, 2000, "GPa"),
    scene_rows::above("sample.wire.mu", 0, 10, ""),
    scene_rows::whole("sample.wire.segments", 2, 1024),
    scene_rows::whole("sample.wire.friction_points", 4, 100000),
    // fewer than 8 Newton-IRLS iterations do not converge from a first contact
    // (measured: the wire overshoots the tip); 8 and 40 agree
    scene_rows::whole("sample.wire.relax_sweeps", 8, 10000),
    scene_rows::in("sample.lithography.threshold_nN", 0, 1e4, "nN"),
    scene_rows::above("sample.lithography.depth_nm_per_nN", 0, 1e4, "nm/nN"),
    scene_rows::above("sample.field_nm", 0, kScannerRangeXY_nm, "nm"),
    // open: the field (f > 0) about this centre must lie inside the scanner's range
    {"sample.field_center_nm[0]", -kScannerRangeXY_nm / 2, kScannerRangeXY_nm / 2, true, true, nullptr, "nm", nullptr},
    {"sample.field_center_nm[1]", -kScannerRangeXY_nm / 2, kScannerRangeXY_nm / 2, true, true, nullptr, "nm", nullptr},
    scene_rows::in("sample.tip_substrate.mu", 0, 10, ""),
    scene_rows::in("sample.tip_substrate.adhesion_nN", 0, 1e6, "nN"),
    scene_rows::in("sample.particle_substrate.mu", 0, 10, ""),
    scene_rows::in("sample.particle_substrate.adhesion_nN", 0, 1e6, "nN"),
    scene_rows::in("sample.particle_substrate.shear_strength_MPa", 0, 1e6, "MPa"),
    scene_rows::in("sample.particle_substrate.contact_area_nm2", 0, 1e9, "nm^2"),
    scene_rows::above("sample.contact_stiffness_N_per_m", 0, 1e4, "N/m"),
    scene_rows::in("sample.photodiode_noise_V", 0, 10, "V"),
    scene_rows::above("sample.temperature_K", 0, 1000, "K"),
    scene_rows::in("sample.drift_nm_per_min[0]", -1e4, 1e4, "nm/min"),
    scene_rows::in("sample.drift_nm_per_min[1]", -1e4, 1e4, "nm/min"),
    scene_rows::in("sample.drift_walk_nm_per_sqrt_min", 0, 1e4, "nm/sqrt(min)"),
    scene_rows::in("sample.roughness_rms_nm", 0, 1000, "nm"),
    scene_rows::above("sample.roughness_corr_nm", 0, 1e5, "nm"),
    scene_rows::above("probe.spring_N_per_m", 0, 1000, "N/m"),
    scene_rows::above("probe.deflection_nm_per_V", 0, 1e4, "nm/V"),
    scene_rows::above("probe.lateral_nN_per_V", 0, 1e5, "nN/V"),
    scene_rows::above("probe.lever_length_um", 0, 1000, "um"),
    scene_rows::above("probe.tip_height_um", 0, 100, "um"),
    scene_rows::above("probe.tip_radius_nm", 0, 1000, "nm"),
    scene_rows::above("probe.tip_half_angle_deg", 0, 80, "deg"),
    scene_rows::in("probe.scan_angle_deg", 0, 360, "deg"),
    scene_rows::above("probe.cn_nm_per_V", 0, 1e4, "nm/V"),
    scene_rows::above("probe.cl_nm_per_V", 0, 1e4, "nm/V"),
    // the card's own rules (fw_card_check, named by the launcher) are narrower: here a whole number
    scene_rows::whole("firmware.adc_bits", -1e6, 1e6, "bits"),
    scene_rows::whole("firmware.word_bits", -1e6, 1e6, "bits"),
    scene_rows::above("firmware.disp_n_nm_per_V", 0, 1e4, "nm/V"),
    scene_rows::above("firmware.disp_l_nm_per_V", 0, 1e4, "nm/V"),
    scene_rows::above("firmware.lateral_nN_per_V", 0, 1e5, "nN/V"),
    scene_rows::in("firmware.mu", 0, 10, ""),
    scene_rows::above("firmware.drift_max_step_nm", 0, 1e6, "nm"),
    scene_rows::in("firmware.drift_walk_nm_per_sqrt_min", 0, 1000, "nm/sqrt(min)"),
    scene_rows::in("firmware.drift_rate_nm_per_min", 0, 10000, "nm/min"),
    scene_rows::in("firmware.drift_scan_sigma_nm", 0, 100, "nm"),
    scene_rows::above("firmware.interlock_normal_nN", 0, 1e6, "nN"),
    scene_rows::above("firmware.interlock_lateral_nN", 0, 1e6, "nN"),
    scene_rows::above("firmware.spring_N_per_m", 0, 1000, "N/m"),
    scene_rows::above("firmware.deflection_nm_per_V", 0, 1e4, "nm/V"),
    scene_rows::above("firmware.lever_length_um", 0, 1000, "um"),
    scene_rows::above("firmware.tip_height_um", 0, 100, "um"),
    scene_rows::above("firmware.tip_radius_nm", 0, 1000, "nm"),
    scene_rows::above("firmware.tip_half_angle_deg", 0, 80, "deg"),
    scene_rows::in("firmware.adhesion_nN", 0, 1e6, "nN"),
    scene_rows::in("firmware.particle_mu", 0, 10, ""),
    scene_rows::in("firmware.particle_adhesion_nN", 0, 1e6, "nN"),
    scene_rows::in("firmware.particle_shear_strength_MPa", 0, 1e6, "MPa"),
    scene_rows::in("firmware.particle_contact_area_nm2", 0, 1e9, "nm^2"),
    scene_rows::above("firmware.wire_friction_nN_per_um", 0, 1e4, "nN/um"),
    scene_rows::above("firmware.wire_mu", 0, 10, ""),
    scene_rows::in("firmware.litho_threshold_nN", 0, 1e4, "nN"),
    scene_rows::above("firmware.litho_depth_nm_per_nN", 0, 1e4, "nm/nN"),
    scene_rows::in("firmware.calibration.mu", 0, 10, ""),
    scene_rows::above("firmware.calibration.lateral_nN_per_V", 0, 1e5, "nN/V"),
    scene_rows::above("firmware.calibration.disp_n_nm_per_V", 0, 1e4, "nm/V"),
    scene_rows::in("firmware.creep_gamma_pct_per_decade", 0, 10, "%"),
    scene_rows::in("firmware.creep_t0_s", 0.001, 100, "s"),
    scene_rows::in("afm.z_speed_nm_per_s", 0, 1e9, "nm/s"),
    // the model's linear part vanishes at 50 % (piezo.hpp: a = 4 w / (1 + 2 w)); labs report 2-23 %
    scene_rows::in("afm.hysteresis.width_pct", 0, 40, "%"),
    scene_rows::above("afm.hysteresis.span_nm", 0, kScannerRangeXY_nm, "nm"),
    scene_rows::in("afm.creep.gamma_pct_per_decade", 0, 20, "%"),
    scene_rows::above("afm.creep.t0_s", 0, 3600, "s"),
    scene_rows::in("afm.scan_artefacts.line_offset_rms_nm", 0, 1000, "nm"),
    scene_rows::in("afm.scan_artefacts.servo_lag_nm", 0, 1e5, "nm"),
    scene_rows::in("afm.scan_artefacts.bow_sag_nm", -1000, 1000, "nm"),
    scene_rows::in("afm.z_drift.rate_nm_per_min", -1e4, 1e4, "nm/min"),
    scene_rows::in("afm.z_drift.walk_nm_per_sqrt_min", 0, 1e4, "nm/sqrt(min)"),
    scene_rows::whole("objects.particles[].id", 0, 1e6),
    scene_rows::in("objects.particles[].x_nm", SceneRef::kFieldXLo, SceneRef::kFieldXHi, "nm"),
    scene_rows::in("objects.particles[].y_nm", SceneRef::kFieldYLo, SceneRef::kFieldYHi, "nm"),
    scene_rows::above("objects.particles[].radius_nm", 0, 5000, "nm"),
    scene_rows::whole("objects.wires[].id", 0, 1e6),
    scene_rows::in("objects.wires[].x0_nm", SceneRef::kFieldXLo, SceneRef::kFieldXHi, "nm"),
    scene_rows::in("objects.wires[].y0_nm", SceneRef::kFieldYLo, SceneRef::kFieldYHi, "nm"),
    scene_rows::in("objects.wires[].x1_nm", SceneRef::kFieldXLo, SceneRef::kFieldXHi, "nm"),
    scene_rows::in("objects.wires[].y1_nm", SceneRef::kFieldYLo, SceneRef::kFieldYHi, "nm"),
    scene_rows::above("objects.wires[].diameter_nm", 0, 5000, "nm"),
    scene_rows::whole("objects.landmarks[].id", 0, 1e6),
    scene_rows::in("objects.landmarks[].x_nm", SceneRef::kFieldXLo, SceneRef::kFieldXHi, "nm"),
    scene_rows::in("objects.landmarks[].y_nm", SceneRef::kFieldYLo, SceneRef::kFieldYHi, "nm"),
    scene_rows::above("objects.landmarks[].side_nm", 0, 20000, "nm"),
    scene_rows::above("objects.landmarks[].height_nm", 0, 5000, "nm"),
    // the scatter tries each particle against the ones drawn (O(count^2)): the bound keeps a check quick (fuzz/README.md)
    scene_rows::whole("objects.scatter.count", 1, 5000),
    scene_rows::above("objects.scatter.radius_nm", 0, 5000, "nm"),
    scene_rows::in("objects.scatter.min_gap_nm", 0, 1e5, "nm"),
    scene_rows::whole("objects.scatter.seed", 0, scene_rows::kSeedMax, "", "a non-negative integer"),
    // [x0, y0, x1, y1] inside the field, x0 < x1 and y0 < y1: the corners' open ends
    {"objects.scatter.region_nm[0]", SceneRef::kFieldXLo, SceneRef::kFieldXHi, false, true, nullptr, "nm", nullptr},
    {"objects.scatter.region_nm[1]", SceneRef::kFieldYLo, SceneRef::kFieldYHi, false, true, nullptr, "nm", nullptr},
    {"objects.scatter.region_nm[2]", SceneRef::kFieldXLo, SceneRef::kFieldXHi, true, false, nullptr, "nm", nullptr},
    {"objects.scatter.region_nm[3]", SceneRef::kFieldYLo, SceneRef::kFieldYHi, true, false, nullptr, "nm", nullptr},
    scene_rows::pair_in("objects.targets[].x_nm", -1e6, 1e6, "the field"),
    scene_rows::pair_in("objects.targets[].y_nm", -1e6, 1e6, "the field"),
    scene_rows::pair_in("objects.targets[][0]", -1e6, 1e6, "the field"),
    scene_rows::pair_in("objects.targets[][1]", -1e6, 1e6, "the field"),
    scene_rows::whole("objects.targets[].particle", 0, 1e6, "", "an integer particle id"),
    scene_rows::in("objects.targets.pitch_nm", 10, 1e5, "nm"),
    scene_rows::in("objects.targets.height_nm", 10, SceneRef::kField, "nm"),
    scene_rows::in("objects.targets.center_nm[0]", -1e6, 1e6, "nm"),
    scene_rows::in("objects.targets.center_nm[1]", -1e6, 1e6, "nm"),
    scene_rows::whole("objects.wire_targets[].id", 0, 1e6),
    scene_rows::in("objects.wire_targets[].x_nm", SceneRef::kFieldXLo, SceneRef::kFieldXHi, "nm"),
    scene_rows::in("objects.wire_targets[].y_nm", SceneRef::kFieldYLo, SceneRef::kFieldYHi, "nm"),
    scene_rows::in("objects.wire_targets[].angle_deg", -360, 360, "deg"),
    scene_rows::in("operator.load_nN", 0, 1000, "nN"),
    scene_rows::in("operator.load_ramp_to_nN", 0, 1000, "nN"),
    scene_rows::in("operator.scan_load_nN", 0, 1000, "nN"),
    scene_rows::above("operator.speed_nm_per_s", 0, 1e6, "nm/s"),
    scene_rows::above("operator.kappa", 0, 1, ""),
    scene_rows::above("operator.feel_threshold_N", 0, 100, "N"),
    scene_rows::in("operator.haptic.half_range_mm", 1, 1000, "mm"),
    scene_rows::in("operator.haptic.max_force_N", 0, 100, "N"),
    scene_rows::above("operator.haptic.max_stiffness_N_per_m", 0, 1e6, "N/m"),
    // the card renders it in whole uN/pN (0.001 N/nN), at most 2^31 / 10^6 N per axis
    scene_rows::in("operator.haptic.force_gain_N_per_nN", 0, 100, "N/nN"),
    scene_rows::in("operator.haptic.damping_Ns_per_m", 0, 1e4, "N s/m"),
    scene_rows::in("operator.haptic.load_span_nN", 0, 1000, "nN"),
    scene_rows::in("operator.hand.stiffness_N_per_m", 0, 1e6, "N/m"),
    scene_rows::in("operator.hand.damping_Ns_per_m", 0, 1e4, "N s/m"),
    scene_rows::above("operator.hand.mass_kg", 0, 100, "kg"),
    scene_rows::above("operator.plan.tolerance_nm", 0, SceneRef::kField, "nm"),
    scene_rows::above("operator.plan.speed_nm_per_s", 0, 1e6, "nm/s"),
    scene_rows::above("operator.plan.travel_speed_nm_per_s", 0, 1e6, "nm/s"),
    scene_rows::above("operator.plan.scan_size_nm", 0, SceneRef::kField, "nm"),
    scene_rows::whole("operator.plan.scan_px", 4, 1024, "px"),
    scene_rows::in("operator.plan.scan_s", 0, 600, "s"),
    scene_rows::whole("operator.plan.max_pushes", 1, 100),
    scene_rows::in("operator.plan.clearance_nm", 0, SceneRef::kField, "nm"),
    scene_rows::in("operator.plan.push_depth_nm", 0, 1000, "nm"),
    scene_rows::above("operator.plan.approach_nm", 0, SceneRef::kField, "nm"),
    scene_rows::above("operator.plan.wire_tolerance_nm", 0, SceneRef::kField, "nm"),
    scene_rows::above("operator.plan.wire_step_nm", 0, SceneRef::kField, "nm"),
    scene_rows::pair_in("operator.plan.cuts[].from_nm[0]", -1e6, 1e6, "the field"),
    scene_rows::pair_in("operator.plan.cuts[].from_nm[1]", -1e6, 1e6, "the field"),
    scene_rows::pair_in("operator.plan.cuts[].to_nm[0]", -1e6, 1e6, "the field"),
    scene_rows::pair_in("operator.plan.cuts[].to_nm[1]", -1e6, 1e6, "the field"),
    // and above sample.lithography.threshold_nN, or nothing is cut (its own check)
    scene_rows::above("operator.plan.cuts[].load_nN", 0, 1e4, "nN"),
    // each waypoint inside the joystick's reach, kappa f/2 about the field's centre
    scene_rows::pair_in("operator.path_nm[][0]", -1e6, 1e6, "the joystick's reach"),
    scene_rows::pair_in("operator.path_nm[][1]", -1e6, 1e6, "the joystick's reach"),
    scene_rows::in("operator.local_scans[].at_s", 0, SceneRef::kDuration, "s"),
    scene_rows::whole("operator.local_scans[].around_id", 0, 1e6),
    scene_rows::above("operator.local_scans[].size_nm", 0, SceneRef::kField, "nm"),
    scene_rows::in("operator.cantilever_changes[].at_s", 0, SceneRef::kDuration, "s"),
    scene_rows::in("operator.cantilever_changes[].offset_nm[0]", SceneRef::kFieldHalfNeg, SceneRef::kFieldHalf, "nm"),
    scene_rows::in("operator.cantilever_changes[].offset_nm[1]", SceneRef::kFieldHalfNeg, SceneRef::kFieldHalf, "nm"),
    scene_rows::whole("outputs.image_px", 16, 4096, "px"),
    scene_rows::whole("outputs.contact_sheet_frames", 0, 100),
};

// The table's key for a key as an error names it: each list index (a [N]
// followed by more of the path) written [], a pair's position kept
// ("objects.particles[3].x_nm" -> "objects.particles[].x_nm",
// "operator.path_nm[2][0]" -> "operator.path_nm[][0]").
std::string scene_range_key(const std::string &key);

// The row of `key` (an error's key, scene_range_key'd); throws
// std::logic_error naming the key when the table has none.
const SceneRange &scene_range(const std::string &key);

// The bound's value for scene s, whose field and duration_s are read
// (std::logic_error when s is null and the bound is the scene's).
double scene_bound(const SceneBound &b, const Scene *s);

// The bound as docs/scenes.md writes it: "45", "0.1", "1e+06", "cx - f/2", "duration_s".
std::string scene_bound_text(const SceneBound &b);

// The row as docs/scenes.md's section "Ranges" shows it, one table line:
// "| `sample.slope_deg` | (0, 45] | deg |".
std::string scene_range_doc_row(const SceneRange &r);

}  // namespace afm
