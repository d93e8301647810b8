// fidelity_diff.png: the paper's check as a figure a person reads. The
// difference displayed - fresh scan (Fidelity::diff_nm, nm) on a diverging
// map (blue: the display lower, white: equal, red: the display higher),
// symmetric about 0 over +-range_nm (diff_range_nm: the 95th percentile
// of |difference| over the pixels that differ at all, rounded up to 1, 2
// or 5 x 10^n, at least 0.5 nm; beyond it the colour saturates), enlarged by a whole factor to at least 512 px;
// each object of the model outlined where the display has it, with its
// position error beside it (or "not found": those first, then the worst,
// at most 12, where there is room); a colour bar in nm; a title
// with the check's figures against its target. Only drawn from the check's
// own numbers: nothing here feeds back into fidelity.json.
#pragma once

#include <opencv2/core.hpp>

#include "display.hpp"
#include "fidelity.hpp"
#include "figure_axes.hpp"
#include "frame_overlay.hpp"

namespace afm {

double diff_range_nm(const cv::Mat &diff_nm);

// layout (optional): what was drawn (figure_axes.hpp).
cv::Mat fidelity_figure(const Fidelity &fid, const Field &f, const DisplayModel &model, double target_nm,
                        FigureLayout *layout = nullptr);

}  // namespace afm
