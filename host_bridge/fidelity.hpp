// The paper's check, automated: after an operation, a fresh scan must match
// the locally updated image. Compares the displayed heights with a fresh
// scan: per object, the position error between where the display shows it
// and where the scan shows it (same estimator on both images, so its bias
// cancels); the RMS height difference; a difference image.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "display.hpp"

namespace afm {

struct ObjectFidelity {
    int id;
    double display_x_nm, display_y_nm;   // located in the displayed image
    double scan_x_nm, scan_y_nm;         // located in the fresh scan
    double error_nm;                     // distance between the two
    bool found;                          // the scan shows a bump there at all
};

struct Fidelity {
    double max_position_error_nm = 0;
    double rms_height_error_nm = 0;
    std::vector<ObjectFidelity> objects;
    cv::Mat diff_nm;                     // displayed - scan, nm (CV_32F)
};

// `search_nm`: how far from the model position an object is looked for.
Fidelity compare_with_scan(const cv::Mat &displayed_nm, const cv::Mat &scan_nm, const Field &f,
                           const std::vector<DisplayObject> &model, const TipShape &tip, double search_nm);

// Locates a bump near (x, y): height-weighted centroid of the pixels above
// half the window's peak. Returns false if the window holds no bump.
bool locate_bump(const cv::Mat &h_nm, const Field &f, double x_nm, double y_nm, double radius_nm, double *cx, double *cy);

// Diverging colour image of a difference (blue negative, red positive, white 0).
cv::Mat diff_image(const cv::Mat &diff_nm, double range_nm);

}  // namespace afm
