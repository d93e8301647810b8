// The firmware's configuration as the lab would flash it, derived from the
// scene's probe and sample: doubles in scene units -> the firmware's integers.
#pragma once

extern "C" {
#include "fw_board.h"
#include "fw_drift.h"
#include "fw_litho.h"
#include "fw_particles.h"
#include "fw_wire.h"
}

#include <cstdint>
#include <string>

#include "scene.hpp"

namespace afm {

// Rounds and saturates to int32 (host side of the analog cable and of the config).
int32_t to_i32(double v);

fw_board_config_t board_config(const Scene &s);
// Why the firmware (fw_board_init, the code itself) refuses board_config(s):
// one line "key: what" naming the scene's keys and values, as SceneError
// does; empty when it accepts it. The launcher checks it before anything
// starts; fw_node says it if init fails anyway.
std::string board_config_refusal(const Scene &s);
// Section 5 threshold F_th = mu_ps (F_adh,ps + F_down) + tau_ps A_c with F_down = 0, nN.
double particle_threshold_nN(const Scene &s);
// Lever-derived displacement constants (section 3 estimate), nm/V.
double cn_estimate_nm_per_V(const ProbeSpec &p);

}  // namespace afm
