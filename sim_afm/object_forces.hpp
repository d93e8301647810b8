// Forces between objects (issue 48, `object_forces`; physics.md section
// 15): the van der Waals attraction between two objects of the sample (a
// Hamaker constant per pair) and the Coulomb force between their charges, so
// that objects near each other attract, repel or jump together, as the paper
// warns. A library of the simulator: World's step does not call it yet.
//
// Bodies: a sphere (a particle: centre, radius) or a rod (a cylinder with
// hemispherical ends: its axis from a to b and its radius, as
// tip_geometry's cylinder and the planar model's stadium). Each carries a
// charge in elementary charges, spread uniformly (a sphere's acts from its
// centre, exact outside a uniformly charged insulating sphere; a rod's along
// its axis). Conductors' image charges are not modelled.
//
// Units: lengths nm, forces nN, energies aJ = nN nm; the Hamaker constant A
// in aJ (1e-19 J = 0.1 aJ); charges in e; the medium's relative
// permittivity eps_r (air 1). e^2 / (4 pi eps0) = kCoulomb_nN_nm2.
//
// The laws (the gap D: the surfaces' distance, centre distance minus the
// radii, the sphere's centre to the rod's axis minus both radii, or two
// rods' axes' least distance, exact, minus both radii):
// - sphere-sphere van der Waals: Hamaker's (1937) exact energy of two
//   spheres of radii R1, R2 at centre distance r, s = R1 + R2, d = R1 - R2,
//     U = -A/6 [2 R1 R2/(r^2 - s^2) + 2 R1 R2/(r^2 - d^2)
//               + ln((r^2 - s^2)/(r^2 - d^2))],
//   and its force F = -dU/dr in closed form; near contact it tends to
//   Derjaguin's -A R1 R2 / (6 (R1 + R2) D^2), far apart to London's
//   -16 A R1^3 R2^3 / (9 r^6) energy.
// - sphere-rod van der Waals: Derjaguin's approximation for surfaces of
//   principal radii (R, R) and (Rc, infinity) (Israelachvili, Intermolecular
//   and Surface Forces, 3rd ed., ch. 13):
//     F = -A / (6 D^2) / sqrt((1/R + 1/Rc) (1/R)),
//   valid for D much smaller than R and Rc (it overestimates further out);
//   zero beyond range_nm (Settings).
// - rod-rod van der Waals is not modelled (refused: a pair of rods with a
//   Hamaker constant throws), nor is retardation.
// - Coulomb: k q1 q2 / (eps_r r^2) between two spheres' centres; a rod's
//   charge as a line along its axis, integrated by 16-point Gauss-Legendre
//   (two rods: 16 x 16 points).
// Below the contact cut-off D0 = kContactCutoffNm (Israelachvili's 0.165 nm)
// the van der Waals force is held at its value at D0: overlap is the
// contact models' domain, not this law's, and the force stays finite.
//
// Out of range: radii in (0, 1e9] nm, |charge| <= 1e9 e, A in [0, 100] aJ,
// eps_r in [1, 1e3], range_nm > 0, positions finite; anything else throws
// InputError naming the field and the value. Two bodies whose centres (or a
// sphere's centre and a rod's axis) coincide have no direction: the force
// is zero (counted by the caller if it cares), never NaN.
#pragma once

#include <Eigen/Dense>

namespace afm::sim::objforce {

// e^2 / (4 pi eps0) in nN nm^2 (CODATA 2018: 8.9875517923e9 N m^2 C^-2 x
// (1.602176634e-19 C)^2 = 2.30707755e-28 N m^2 = 0.230707755 nN nm^2).
constexpr double kCoulomb_nN_nm2 = 0.230707755;
// The van der Waals law's contact cut-off, nm (Israelachvili ch. 13.13).
constexpr double kContactCutoffNm = 0.165;
// 1 J = 1e18 aJ: a Hamaker constant in J to aJ (nN nm).
constexpr double kAttojoulePerJoule = 1e18;

struct Body {
    enum class Kind { sphere, rod };
    Kind kind = Kind::sphere;
    Eigen::Vector3d a_nm = Eigen::Vector3d::Zero();   // a sphere's centre; a rod's axis start
    Eigen::Vector3d b_nm = Eigen::Vector3d::Zero();   // a rod's axis end (a sphere: unused)
    double radius_nm = 0;
    double charge_e = 0;
};

// One pair's constants.
struct Settings {
    double hamaker_aJ = 0;      // A of the pair (0: no van der Waals)
    double eps_r = 1;           // the medium's relative permittivity
    double range_nm = 100;      // gap beyond which the van der Waals force is 0
};

// The force on the second body from the first (nN), and the gap (nm).
struct PairForce {
    Eigen::Vector3d on_second_nN = Eigen::Vector3d::Zero();
    double gap_nm = 0;
};

// Hamaker's sphere-sphere energy (aJ) and radial force (nN, positive
// repulsive: F = -dU/dr) at centre distance r_nm; the gap below
// kContactCutoffNm is held there (header). A in aJ.
double vdw_sphere_sphere_energy(double A_aJ, double R1_nm, double R2_nm, double r_nm);
double vdw_sphere_sphere_force(double A_aJ, double R1_nm, double R2_nm, double r_nm);
// Derjaguin's sphere-cylinder force (nN, negative attractive) at gap D.
double vdw_sphere_rod_force(double A_aJ, double R_nm, double Rc_nm, double gap_nm);

// The whole force between two bodies (van der Waals + Coulomb), on the
// second. Throws InputError out of range (header).
PairForce between(const Body &first, const Body &second, const Settings &s);

}  // namespace afm::sim::objforce
