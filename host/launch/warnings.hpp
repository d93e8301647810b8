// What ./afm check warns about in a scene that is valid but likely not what
// its author meant (issue 37): each warning names the key and the reason.
//   - a scripted path segment that pushes a particle within the cone about
//     the lever's axis where the card cannot see F_x (|sin theta| below
//     fw_force.h's S_HI, 14.5 deg): the card's model then stays behind;
//   - particles to push without the adhesion effect (they hold by nothing:
//     the first touch slides them away);
//   - a load beyond the card's normal full scale (k_n K_n 10 V) or its
//     interlock limit.
// (A path off the scan field is an error already: the joystick cannot reach
// it, scene/scene.cpp.)
// A scene's expect: silences the warnings of a failure it expects
// (unobservable_push, saturation, interlock). --strict makes them errors.
#pragma once

#include <string>
#include <vector>

extern "C" {
#include "fw_card.h"
}
#include "scene.hpp"

namespace afm {

std::vector<std::string> scene_warnings(const Scene &s, const fw_card_config_t &card);

}  // namespace afm
