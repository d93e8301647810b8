// The tip's wear by Archard's law, the apex growing in its cone
// (tip_wear.hpp; physics.md 16).
#include "tip_wear.hpp"

#include <cmath>
#include <sstream>

#include "process.hpp"

namespace afm::sim::wear {

namespace {

[[noreturn]] void refuse(const char *field, const char *want, double got)
{
    std::ostringstream o;
    o << "tip wear: " << field << " must be " << want << ", got " << got;
    throw InputError(o.str());
}

void check_gamma(double g)
{
    if (!(g > 0 && g <= 80.0 * M_PI / 180)) refuse("half angle (rad)", "in (0, 80 deg]", g);
}

void check_radius(double r)
{
    if (!(r >= 0 && r <= 1e6)) refuse("radius_nm", "in [0, 1e6]", r);
}

}  // namespace

double blunt_coefficient(double g)
{
    check_gamma(g);
    const double s = std::sin(g), c = std::cos(g);
    return M_PI * (c * c / s - 2.0 / 3 * (1 - s * s * s) - 2.0 / 3 * c * c * c * c / s);
}

double blunt_volume_nm3(double r, double g)
{
    check_radius(r);
    return blunt_coefficient(g) * r * r * r;
}

// Scaling: volumes in nm^3; R^3 of R <= 1e6 nm is 1e18, far from double's
// range. A negative worn volume is refused (wear does not grow a tip back).
double radius_after(double r, double g, double worn)
{
    if (!(worn >= 0 && std::isfinite(worn))) refuse("worn_nm3", "finite and >= 0", worn);
    return std::cbrt(r * r * r + worn / blunt_coefficient(g));
}

TipWear::TipWear(double radius_nm, double gamma_rad, const Archard &law)
    : r0_(radius_nm), radius_(radius_nm), gamma_(gamma_rad), law_(law)
{
    check_radius(radius_nm);
    check_gamma(gamma_rad);
    if (!(law.k >= 0 && law.k <= 1)) refuse("wear coefficient k", "in [0, 1]", law.k);
    if (!(law.hardness_GPa > 0 && law.hardness_GPa <= 1e3)) refuse("hardness_GPa", "in (0, 1e3]", law.hardness_GPa);
}

void TipWear::slide(double load_nN, double distance_nm)
{
    if (!std::isfinite(load_nN)) refuse("load_nN", "finite", load_nN);
    if (!(distance_nm >= 0 && std::isfinite(distance_nm))) refuse("distance_nm", "finite and >= 0", distance_nm);
    slid_ += distance_nm;
    if (load_nN <= 0) return;
    worn_ += law_.k * load_nN * distance_nm / law_.hardness_GPa;
    radius_ = radius_after(r0_, gamma_, worn_);
}

}  // namespace afm::sim::wear
