// The height profile an AFM scan shows of a sphere on a flat substrate, as a
// function of the horizontal distance rho from its centre: the sphere dilated
// by a tip with a spherical apex (radius r_t) on a cone of half angle gamma
// (physics.md section 11). Closed form, nm.
#pragma once

namespace afm {

struct TipShape {
    double radius_nm = 0;        // apex radius r_t; 0 with gamma 0 = no tip convolution
    double half_angle_deg = 0;   // cone half angle gamma; 0 = ideal tip (true topography)
};

// Imaged height over a sphere of radius R at horizontal distance rho, nm (>= 0).
double sphere_profile_nm(double R, double rho, const TipShape &tip);
// Smallest rho at which the profile is 0 (the footprint's radius), nm.
double sphere_footprint_nm(double R, const TipShape &tip);

}  // namespace afm
