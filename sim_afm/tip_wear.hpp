// The tip's wear (issue 48, `tip_wear`; physics.md section 16): the apex
// radius grows with the distance slid under load, by Archard's law, and the
// tip keeps its shape (a cone of half angle gamma with a tangent spherical
// apex, tip_geometry.hpp) with the larger radius. A library of the
// simulator: World's step does not call it yet.
//
// Archard (1953): the volume worn V = k N s / H, k the dimensionless wear
// coefficient, N the normal load (only a pressing load wears; N <= 0 wears
// nothing), s the distance slid, H the tip's hardness. Units: N nN, s nm,
// H GPa = nN/nm^2, so V = k N s / H is in nm^3 with no conversion.
//
// The shape: a tip of apex radius R lacks, against the sharp cone of the
// same flank, the volume between the cone and the apex's sphere,
//   V_blunt(R) = c(gamma) R^3,
//   c(gamma) = pi [cos^2 g / sin g - (2/3)(1 - sin^3 g) - (2/3) cos^4 g / sin g]
// (the solid of revolution between the sphere's cap, below its tangent
// circle at radius R cos g, and the cone's tip; the flank above is common to
// both). Worn volume V takes R0 to the R with V_blunt(R) = V_blunt(R0) + V:
//   R = (R0^3 + V / c(gamma))^(1/3),
// the wear flat of a real tip idealised as a blunter sphere, which is how
// tip radii are reported from blind reconstruction (Villarrubia 1997).
//
// Out of range: gamma in (0, 80] deg (the scene's probe), R0 in [0, 1e6]
// nm, k in [0, 1], H in (0, 1e3] GPa, N and s finite, s >= 0; anything else
// throws InputError naming the field and value.
#pragma once

namespace afm::sim::wear {

// c(gamma) above (gamma in rad), and V_blunt(R) = c R^3 in nm^3.
double blunt_coefficient(double gamma_rad);
double blunt_volume_nm3(double radius_nm, double gamma_rad);
// The radius after `worn_nm3` more is worn off a tip of radius R0.
double radius_after(double radius_nm, double gamma_rad, double worn_nm3);

struct Archard {
    double k = 1e-4;            // wear coefficient (dimensionless)
    double hardness_GPa = 10;   // the tip's (silicon: about 10 GPa)
};

// A tip wearing as it slides.
class TipWear {
public:
    TipWear(double radius_nm, double gamma_rad, const Archard &law);
    // Slides `distance_nm` under `load_nN`; the radius follows.
    void slide(double load_nN, double distance_nm);
    double radius_nm() const { return radius_; }
    double worn_nm3() const { return worn_; }
    double slid_nm() const { return slid_; }

private:
    double r0_, radius_, gamma_;
    Archard law_;
    double worn_ = 0, slid_ = 0;
};

}  // namespace afm::sim::wear
