#include "lever.hpp"

#include <cmath>

namespace afm::sim {

Lever::Lever(const ProbeSpec &p)
{
    spring = p.spring_N_per_m;                 // N/m == nN/nm
    deflection = p.deflection_nm_per_V;
    l = p.lever_length_um * 1e3;
    h = p.tip_height_um * 1e3;
    Kl = 3.0 * deflection / (2.0 * l);
    ktheta = p.lateral_nN_per_V * h / Kl;
    alpha = (p.scan_angle_deg - 270.0) * M_PI / 180.0;
    R << std::cos(alpha), -std::sin(alpha), std::sin(alpha), std::cos(alpha);
    const double beam_c = 3.0 * h * deflection / (2.0 * l);   // nm/V
    if (p.cn_nm_per_V) cn_scale = *p.cn_nm_per_V / beam_c;
    if (p.cl_nm_per_V) cl_scale = *p.cl_nm_per_V / beam_c;
}

double Lever::bend_slope(double fx_C, double fz) const
{
    // Euler-Bernoulli cantilever, EI = k_n l^3 / 3: an end load F gives slope
    // F l^2 / (2 EI) = 3 F / (2 k_n l); an end moment M gives M l / EI.
    const double EI = spring * l * l * l / 3.0;
    const double moment = fx_C * h;
    return fz * l * l / (2.0 * EI) + moment * l / EI;
}

double Lever::twist(double fy_C) const { return fy_C * h / ktheta; }

Eigen::Vector2d Lever::apex_offset(const Eigen::Vector2d &f_A, double fz) const
{
    const Eigen::Vector2d fC = R.transpose() * f_A;
    // Rotating the end by the slope about -y swings the apex (h below) towards +x;
    // twisting about +x swings it towards +y.
    return R * Eigen::Vector2d(cn_scale * h * bend_slope(fC.x(), fz), cl_scale * h * twist(fC.y()));
}

Eigen::Matrix2d Lever::stiffness_A() const
{
    const double EI = spring * l * l * l / 3.0;
    const double kx = EI / (cn_scale * h * h * l);   // cn h (F_x h) l / EI = F_x / kx
    const double ky = ktheta / (cl_scale * h * h);
    Eigen::Matrix2d KC;
    KC << kx, 0, 0, ky;
    return R * KC * R.transpose();
}

Eigen::Vector2d Lever::normal_offset(double fz) const { return R * Eigen::Vector2d(cn_scale * h * bend_slope(0.0, fz), 0.0); }

}  // namespace afm::sim
