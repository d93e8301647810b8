// What a real scan line shows besides the surface (effect scan_artefacts,
// physics.md section 17.3), applied to scans only, never to the truth or
// the mechanics; afm.scan_artefacts gives each level:
//   - a line offset: each line's heights shifted by one draw of a normal
//     law of rms line_offset_rms_nm (its own generator, seeded from the
//     scene's seed: the physics' stream is untouched);
//   - the z servo's tracking error: the height follows the surface through
//     a first-order lag along the fast axis of length servo_lag_nm (the
//     servo's time constant times the tip's speed), h'_0 = h_0,
//     h'_i = h'_(i-1) + (1 - exp(-dx / lag)) (h_i - h'_(i-1)); what z has not
//     followed, h_i - h'_i, bends the lever (the error signal, in S_n);
//   - the scanner's bow: -sag ((x - cx)^2 + (y - cy)^2) / (f / 2)^2 added to
//     every height, (cx, cy) the field's centre and f its side, so the bow
//     is bow_sag_nm low at the middle of the field's edges.
#pragma once

#include <random>

#include "scene.hpp"

namespace afm::sim {

class ScanArtefacts {
public:
    explicit ScanArtefacts(const Scene &s);
    // One line at x_i = x0 + i dx (i < n), y (frame A, nm): height_nm[i]
    // gets the artefacts; error_nm[i] is set to the servo's tracking error.
    void apply(double x0, double dx, double y, int n, double *height_nm, double *error_nm);
    double bow_nm(double x, double y) const;

private:
    double offset_rms_nm_, lag_nm_, sag_nm_, cx_, cy_, half_;
    std::mt19937_64 rng_;
    std::normal_distribution<double> gauss_{0.0, 1.0};
};

}  // namespace afm::sim
