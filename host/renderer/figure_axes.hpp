// The figures a run writes besides its frames, for print: scan_initial.png
// (the first scan's heights) and fidelity_diff.png (fidelity_figure.hpp).
//
// A figure is a square picture of the field, each display pixel a square
// of frame_px(px) / px figure pixels (at least kMinFramePx across, as a
// frame), on white, with:
//   - its title lines above it;
//   - axes in nm left of and below it: a round step (1, 2, 2.5 or 5 x 10^n
//     nm, 3 to 6 ticks), each tick pointing out of the picture and its
//     label beyond the tick (negatives with the minus sign U+2212), the
//     axes named "x (nm)" below and "y (nm)" above the y labels;
//   - a colour bar right of it: the picture's colours from `hi` (top) to
//     `lo` (bottom), its ticks and their labels in the bar's unit, the unit
//     above it.
// Texts are DejaVu Sans (frame_font.hpp) at figure_text(): a capital 11 px
// high; none touches another or a tick (2 px at least between inks), all
// inside the figure. What was drawn is returned in a FigureLayout (the
// picture's texts, drawn by the caller, included) for tests to check.
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "display.hpp"
#include "frame_font.hpp"
#include "frame_overlay.hpp"

namespace afm {

// The figures' text (renderer_report.json fidelity_label_cap_px: its capitals' height).
FrameText figure_text();

struct FigureBar {
    cv::Mat gradient;            // BGR, one column: row 0 is `hi`, the last row `lo`
    double lo = 0, hi = 1;       // the values at its ends
    std::vector<double> ticks;   // values to label, within [lo, hi]
    bool plus = false;           // positive labels with "+" (a difference)
    std::string unit = "nm";
};

struct FigureLayout {
    std::vector<TextBox> texts;
    std::vector<cv::Rect> axes;   // the picture's frame, the ticks, the colour bar
    cv::Rect picture;             // where the picture lies in the figure
};

// The figure round `picture` (square, frame_px(f.px) a side, BGR), whose
// own texts (picture coordinates) are `inner`.
cv::Mat axes_figure(const cv::Mat &picture, const Field &f, const std::vector<std::string> &title, const FigureBar &bar,
                    const std::vector<TextBox> &inner = {}, FigureLayout *layout = nullptr);

// Round ticks over [lo, hi]: 1, 2, 2.5 or 5 x 10^n apart, 3 to 6 of them.
std::vector<double> round_ticks(double lo, double hi);

// scan_initial.png: a scan's heights (nm, f.px square) in the display's
// colours and scale, its colour bar in nm.
cv::Mat scan_figure(const Display &d, const cv::Mat &scan_nm, const std::string &title, FigureLayout *layout = nullptr);

}  // namespace afm
