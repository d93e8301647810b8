#include "profile.hpp"

#include <algorithm>
#include <cmath>

namespace afm {

double sphere_profile_nm(double R, double rho, const TipShape &tip)
{
    rho = std::fabs(rho);
    if (tip.half_angle_deg <= 0) return rho < R ? R + std::sqrt(R * R - rho * rho) : 0.0;
    // The tip is a sharp cone K0 (apex at the apex sphere's centre) dilated by
    // a ball of radius r_t: it touches the particle when the particle's centre
    // is R + r_t from K0: on the apex sphere while the contact normal is within
    // 90 deg - gamma of vertical, on the flank beyond.
    const double g = tip.half_angle_deg * M_PI / 180.0;
    const double Rt = R + tip.radius_nm;
    const double rho_switch = Rt * std::cos(g);
    double z;
    if (rho <= rho_switch) z = R + std::sqrt(Rt * Rt - rho * rho) - tip.radius_nm;
    else z = R - (rho * std::cos(g) - Rt) / std::sin(g) - tip.radius_nm;
    return std::max(0.0, z);
}

double sphere_footprint_nm(double R, const TipShape &tip)
{
    if (tip.half_angle_deg <= 0) return R;
    const double g = tip.half_angle_deg * M_PI / 180.0;
    const double Rt = R + tip.radius_nm;
    // Flank height reaches 0: R - (rho cos g - Rt) / sin g - r_t = 0.
    const double flank = (Rt + (R - tip.radius_nm) * std::sin(g)) / std::cos(g);
    // If the apex sphere part already reaches the substrate (a blunt tip on a
    // small sphere), the footprint ends there.
    const double sph2 = Rt * Rt - (tip.radius_nm - R) * (tip.radius_nm - R);
    const double sph = std::sqrt(std::max(0.0, sph2));
    return (tip.radius_nm > R && sph <= Rt * std::cos(g)) ? sph : flank;
}

double wire_profile_nm(double R, double rho, const TipShape &tip) { return sphere_profile_nm(R, rho, tip); }

double wire_footprint_nm(double R, const TipShape &tip) { return sphere_footprint_nm(R, tip); }

double groove_profile_nm(double depth_nm, double half_width_nm, double u_nm, const TipShape &tip)
{
    u_nm = std::fabs(u_nm);
    if (depth_nm <= 0 || half_width_nm <= 0 || u_nm >= half_width_nm) return 0.0;
    double z = depth_nm * (1 - u_nm / half_width_nm);
    if (tip.half_angle_deg > 0) z = std::min(z, (half_width_nm - u_nm) / std::tan(tip.half_angle_deg * M_PI / 180.0));
    return z;
}

}  // namespace afm
