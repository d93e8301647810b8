// The force loop's stability bound: the largest gain at which the card's
// force, rendered on the haptic device (operator/haptic_device.hpp), keeps
// the loop passive. The card's gain when a scene leaves it to the bench
// (card_setup.cpp) comes from it; the launcher refuses a scene outside it.
//
// The stability bound. Through the lever, the stiffest thing the tip can
// meet changes the force by at most k_c per nm of apex motion, k_c the
// lever's in-plane stiffness (lateral gain / C_l and normal gain / C_n,
// the larger, with the firmware's estimate C = 3 h K_n / (2 l)). Seen at the
// stylus that is a spring K_r = g k_c s, s = kappa (field / 2) / half_range
// the apex's motion per stylus motion. A sampled spring behind a delay of d
// periods T, held for one, is passive (Colgate and Schenkel 1997, with the
// delay) when the device's damping dissipates what the lag puts in:
//
//     b > K_r T (1/2 + d),     i.e.  K_r < K_max = b / (T (1/2 + d))
//
// whatever the hand does (the free stylus is the worst case: the hand adds
// damping). haptic_bound() states it for a scene; the launcher refuses a
// scene outside it, naming the keys and the largest gain that passes,
// unless operator.haptic.passivity_check is false. Beyond the bound, and
// for what it does not cover (a contact that never yields: the card's
// compensation moves the piezo on every block, an integrator, until the
// card's limit), the device runs a passivity observer and controller
// (Hannaford and Ryu 2002): it sums the energy the stylus gives the device
// and, when the device has given back more than it took, adds exactly the
// damping that dissipates the excess. The loop cannot grow an oscillation;
// the report says how much the controller took out.
//
// The third axis (operator.haptic.load_span_nN > 0). The hand presses the
// stylus down to set the load: the pose asks for load_span x depth /
// half_range (depth below the centre, 0 above it), and the card renders
// g F_z upwards on it. Through the z servo the load follows the pose, so
// the stylus meets a spring K_z = g load_span / half_range behind the same
// delay; haptic_bound() holds it to the same K_max (it is usually far
// softer than the in-plane one: a load span of tens of nN against the
// lever's in-plane stiffness over the field). Without it z is not
// integrated and the load comes from the script or the page.
//
// Units: N/m, N/nN, s; the card's gains in whole uN/pN.
#pragma once

extern "C" {
#include "fw_card.h"
}

#include <cstdint>
#include <string>

#include "scene.hpp"

namespace afm {

struct HapticBound {
    double lever_N_per_m = 0;        // k_c
    double gain_N_per_N = 0;         // g, as the card renders it (whole uN/pN)
    double scale = 0;                // s: apex metres per stylus metre
    double rendered_N_per_m = 0;     // K_r = g k_c s
    double rendered_z_N_per_m = 0;   // K_z = g load_span / half_range (0: no z axis)
    double period_s = 0;             // T: one block
    double delay_blocks = 2;         // d
    double max_rendered_N_per_m = 0; // K_max = b / (T (1/2 + d))
    double max_gain_N_per_nN = 0;    // the largest gain inside both limits
    bool passive = false;            // K_r and K_z < K_max
    bool within_device = false;      // K_r and K_z <= max_stiffness_N_per_m
};

// k_c: the lever's in-plane stiffness as the card knows it (the larger of
// its lateral and normal gains over the firmware's displacement estimate),
// N/m; 0 when the firmware refuses the lever.
double lever_stiffness_N_per_m(const fw_board_config_t &b);
// The bound for the scene and the card's configuration (its gain).
HapticBound haptic_bound(const Scene &s, const fw_card_config_t &card);
// The gain when the scene leaves it to the bench (force_gain_N_per_nN
// auto): 4/5 of the largest inside both limits, in the card's whole uN/pN
// (at least 1).
int32_t haptic_auto_gain_un_per_pn(const Scene &s, const fw_board_config_t &b);
// One line naming the keys and values when the scene is outside the bound
// (or the device's stiffness) and passivity_check is on; empty otherwise.
std::string haptic_refusal(const Scene &s, const fw_card_config_t &card);

}  // namespace afm
