// The frame a researcher reads: the display's height image, colourised,
// enlarged by a whole factor to at least kMinFramePx (frame_px(): the
// display's size is the scene's outputs.image_px, its pixels the scan's),
// with an overlay drawn at the frame's own size on a copy of it. The height
// image itself (Display::height(), which the fidelity check compares with a
// fresh scan and display_final.gsf keeps) is never drawn on: markers, ids,
// labels and glyphs exist only in the returned BGR frame.
//
// What the overlay shows (docs/design.md "What a run writes"):
//   - axes in um along the left and bottom edges, on dark bands over the
//     image's edges: the axis line, ticks pointing out of the image from
//     it, and each tick's label beyond the tick (a y label ends left of its
//     tick, so that the tick never reads as a minus sign; negatives have
//     the minus sign U+2212); "µm" in the bands' corner;
//   - each particle ringed by a marker at least kMinMarkerPx across, with
//     its id (p<id>) beside it where no other text or ring is (a dense
//     pattern keeps its rings and names what it can); wires (w<id>) and
//     trenches (t<id>) named likewise;
//   - the lever: a faint line from the tip back along its axis towards its
//     base, labelled where there is room, and, while the tip pushes
//     (FLAG_CONTACT), the faint cones about the axis within which the card
//     cannot see F_x (half angle asin(S_HI), fw_force.h; LeverView);
//   - the force on the tip as a 3-D glyph: the lateral force an arrow from
//     the tip, F_z a bar beside it (up: the sample pushes the tip up), with
//     a legend above the x axis giving each glyph's scale in nN and the
//     values;
//   - the hand's gauge: a ring of hand_scale_N, an arrow for the force on
//     the stylus, and in words "hand feels 31 mN, ring 80 mN";
//   - time and status flags top left, the height colour bar in nm at the
//     right edge, the interlock's red border and banner.
// Text: DejaVu Sans (frame_font.hpp) at frame_text(frame px): a capital at
// least 10 px high at 512 px, growing with the frame. No text touches
// another (2 px at least between their inks), none lies on the axes' bands
// but the axes' own, and every text lies inside the frame; what a frame
// drew is returned in a FrameLayout for tests to check.
#pragma once

#include <opencv2/core.hpp>

#include "display.hpp"
#include "frame_font.hpp"

#include <vector>

namespace afm {

constexpr int kMinMarkerPx = 9;   // an object's marker, across, at least (pixels of the frame)
constexpr int kMinFramePx = 512;  // a frame's side, at least

// A frame's side for a display of display_px: display_px times the least
// whole factor that reaches kMinFramePx (each display pixel a square of
// the frame's).
int frame_px(int display_px);

// The lever's axis in the image and the cone where F_x is unobservable.
struct LeverView {
    double axis[2] = {1, 0};          // x_C in frame A, unit: from the lever's base to its tip
    double blind_half_angle_deg = 0;  // |angle to the axis| below which F_x is unobservable
};
// From the scene's scan angle, by the firmware's own function and threshold
// (fw_board_lever_axis_q30; S_HI of fw_force.h).
LeverView lever_view(double scan_angle_deg);

struct FrameText {
    int font_px;        // FreeType's pixel size (frame_font.hpp)
    int cap_px;         // a capital's height, frame pixels (its ink)
    int line_px;        // from one line of text to the next
};
FrameText frame_text(int frame_px);

// What a frame drew: every text, and the axes' lines and ticks.
struct FrameLayout {
    std::vector<TextBox> texts;
    std::vector<cv::Rect> axes;    // the axis lines and their ticks
    std::vector<cv::Rect> bands;   // the axes' bands (only their own texts there)
};

// The frame: the display's colourised heights and the overlay above.
// layout (optional): filled with what was drawn.
cv::Mat compose_frame(const Display &d, const DisplayModel &model, const Overlay &o, const LeverView &lever,
                      FrameLayout *layout = nullptr);

}  // namespace afm
