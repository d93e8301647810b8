// The cantilever and its photodiode (physics.md sections 0, 1, 3), in double
// precision, from beam theory, independent of the firmware's closed forms.
//
// Frames: C (x along the lever from base to tip, y lateral, z up) and A (the
// scanner's), alpha = scan_angle - 270 deg about z. Forces are the force of
// the sample on the tip. Units: nm, nN (so stiffness in nN/nm = N/m), V, rad.
#pragma once

#include <Eigen/Dense>

#include "scene.hpp"

namespace afm::sim {

struct Lever {
    // From the scene
    double spring;    // normal spring constant k_n, nN/nm
    double deflection;   // normal gain K_n, nm/V (deflection per volt)
    double l;         // lever length, nm
    double h;         // tip height, nm
    double Kl;        // lateral photodiode gain, rad/V (3 K_n / (2 l): equal sensitivity)
    double ktheta;    // torsional constant, nN nm / rad (from lateral_nN_per_V = k_theta K_l / h)
    double alpha;     // scan angle - 270 deg, rad
    // The real lever against the beam: its apex moves cn_scale (cl_scale)
    // times what 3 h K_n / (2 l) gives per volt of S_n (S_l) (probe.cn_nm_per_V,
    // probe.cl_nm_per_V; 1: the beam's own).
    double cn_scale = 1, cl_scale = 1;
    Eigen::Matrix2d R;   // C -> A (lateral)

    explicit Lever(const ProbeSpec &p);

    // End slope of the lever (rad) seen by the photodiode: end load F_z plus the
    // moment F_x h of a force along the lever acting h below it.
    double bend_slope(double fx_C, double fz) const;
    // Twist angle (rad) from the lateral force F_y acting h below the axis.
    double twist(double fy_C) const;
    // Photodiode outputs before saturation, V.
    double sn_volts(double fx_C, double fz) const { return bend_slope(fx_C, fz) * (2.0 * l / 3.0) / deflection; }
    double sl_volts(double fy_C) const { return twist(fy_C) / Kl; }
    // Apex displacement from the undeformed tip, frame A, nm: the tip turns
    // with the lever's end, so the apex moves by h times each angle.
    Eigen::Vector2d apex_offset(const Eigen::Vector2d &f_A, double fz) const;
    // Lateral stiffness of the apex against the force, frame A, nN/nm
    // (apex_offset = K^-1 f + normal-load part).
    Eigen::Matrix2d stiffness_A() const;
    // The part of apex_offset due to the normal load alone, frame A, nm.
    Eigen::Vector2d normal_offset(double fz) const;
};

constexpr double kSignalLimitV = 10.0;   // photodiode outputs saturate at +-10 V

}  // namespace afm::sim
