// The planner's target sites (objects.targets): a list of positions, or a
// text or a PNG mask rasterised into sites at a pitch.
//
// Text: OpenCV's Hershey simplex font drawn one pixel per site (a pixel is
// pitch_nm), one pixel thick, the letters height_nm tall (the cap height),
// centred on center_nm: the strokes are rows and columns of sites, as a
// dot-matrix display draws letters. PNG: the mask (dark pixels, below half
// grey, are the pattern) scaled to height_nm tall, its aspect kept,
// centred on center_nm, at 16 pixels per pitch; a site at every node of a
// square grid of the pitch whose cell the mask covers by at least half.
// Sites outside the field are an error, as are no sites at all.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "scene.hpp"

namespace afm {

// Targets the planner cannot serve (an input error: exit 2, process.hpp).
class PatternError : public InputError {
public:
    using InputError::InputError;
};

// The sites, frame A at zero drift (the sample's coordinates), nm, in
// rows from the top, left to right. Throws PatternError naming the scene
// key ("<file>: objects.targets...: ...").
std::vector<Vec2> target_sites(const Scene &s);

// One line naming the problem when the scene's targets cannot be served
// (sites outside the field, more sites than particles); empty if they can.
std::string targets_refusal(const Scene &s);

}  // namespace afm
