// The height profiles an AFM scan shows of the modelled objects on a flat
// substrate (physics.md sections 9, 11), closed forms, nm:
// - a sphere, as a function of the horizontal distance rho from its centre:
//   the sphere dilated by a tip with a spherical apex (radius r_t) on a cone
//   of half angle gamma;
// - a wire (a cylinder lying on the substrate, hemispherical caps), as a
//   function of the distance from its axis: the same cross-section;
// - a lithography V-groove, as a function of the distance from its path: the
//   groove where the tip's cone fits into it, the cone's own V where the
//   groove is narrower.
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

// Imaged height over a wire of radius R (diameter d = 2R) lying on the
// substrate, at distance rho from its axis (the segment or polyline: beyond an
// end the distance to the end node, so the ends are hemispherical caps), nm.
// The tip is rotationally symmetric and the cylinder invariant along its
// axis, so the tip first touches it in the vertical plane across the axis:
// the cross-section is the sphere's, with rho measured from the axis. Its top
// is d under any tip.
double wire_profile_nm(double R, double rho, const TipShape &tip);
// Distance from the axis at which the wire's profile reaches 0, nm.
double wire_footprint_nm(double R, const TipShape &tip);

// Imaged depth (positive, below the substrate) of a V-groove of the given
// depth and surface half width, at distance u from its path, nm. A tip whose
// cone (half angle gamma) is wider than the groove stops on its rims: the
// image is then the cone's V, (half_width - u) cot gamma deep. The apex
// sphere is not resolved in the groove (a groove cut by this tip fits it).
double groove_profile_nm(double depth_nm, double half_width_nm, double u_nm, const TipShape &tip);

}  // namespace afm
