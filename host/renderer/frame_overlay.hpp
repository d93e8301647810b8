// The frame a researcher reads: the display's height image, colourised,
// with an overlay drawn on a copy of it. The height image itself
// (Display::height(), which the fidelity check compares with a fresh scan
// and display_final.gsf keeps) is never drawn on: markers, ids, labels and
// glyphs exist only in the returned BGR frame.
//
// What the overlay shows (docs/design.md "What a run writes"):
//   - axes along the left and bottom edges, ticks and labels in um (frame A);
//   - each particle ringed by a marker at least kMinMarkerPx across (its
//     image may be 5 px at 256 px), with its id (p<id>) beside it where no
//     other label or ring is (a dense pattern keeps its rings and names
//     what it can); wires (w<id>) and trenches (t<id>) named likewise;
//   - the lever: a faint line from the tip back along its axis towards its
//     base, and, while the tip pushes (FLAG_CONTACT), the faint cones about
//     the axis within which the card cannot see F_x (half angle
//     asin(S_HI), fw_force.h; LeverView);
//   - the force on the tip as a 3-D glyph: the lateral force an arrow from
//     the tip, F_z a bar beside it (up: the sample pushes the tip up), with
//     a legend giving each glyph's scale in nN and the values;
//   - the hand's gauge: a ring of hand_scale_N, an arrow for the force on
//     the stylus, and in words "hand feels 31 mN, ring 80 mN";
//   - time, status flags, the height colour bar in nm, the interlock's red
//     border and banner.
// Text size: labels are drawn at frame_text(px): a capital at least
// kMinLabelPx high at 256 px and growing with the frame (the report shows
// frames at least 512 px wide, analysis/run_report.py).
#pragma once

#include <opencv2/core.hpp>

#include "display.hpp"

namespace afm {

constexpr int kMinMarkerPx = 9;   // an object's marker, across, at least (pixels of the frame)

// The lever's axis in the image and the cone where F_x is unobservable.
struct LeverView {
    double axis[2] = {1, 0};          // x_C in frame A, unit: from the lever's base to its tip
    double blind_half_angle_deg = 0;  // |angle to the axis| below which F_x is unobservable
};
// From the scene's scan angle, by the firmware's own function and threshold
// (fw_board_lever_axis_q30; S_HI of fw_force.h).
LeverView lever_view(double scan_angle_deg);

struct FrameText {
    double scale;       // cv::FONT_HERSHEY_PLAIN scale
    int cap_px;         // a capital's height, frame pixels (cv::getTextSize)
    int line_px;        // from one line of text to the next
};
FrameText frame_text(int px);

// A label's pixel: the channel p under an outline of opacity o (0-255)
// darkened to p (255 - o) / 255, then text of opacity t in colour c (a whole
// 0-255 value) over it, rounded to the nearest byte. Exactly
// (p (255 - o) (255 - t) + 255 c t) / 65025, which is never a tie (65025
// is odd): the bytes of the same formula evaluated in doubles, in integers.
inline unsigned char label_blend(int p, int o, int t, int c)
{
    const int n = p * (255 - o) * (255 - t) + 255 * c * t;
    return static_cast<unsigned char>((2 * n + 65025) / 130050);
}

// The frame: the display's colourised heights and the overlay above.
cv::Mat compose_frame(const Display &d, const DisplayModel &model, const Overlay &o, const LeverView &lever);

}  // namespace afm
