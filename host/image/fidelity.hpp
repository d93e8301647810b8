// The paper's check, automated: after an operation, a fresh scan must match
// the locally updated image. Compares the displayed heights with a fresh
// scan: per object, the position error between where the display shows it
// and where the scan shows it (same estimator on both images, so its bias
// cancels); the RMS height difference (trenches count there); a difference
// image.
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

#include "display.hpp"

namespace afm {

struct ObjectFidelity {
    std::string kind;                    // "particle" or "wire"
    int id;
    double display_x_nm, display_y_nm;   // located in the displayed image (a wire: its centroid)
    double scan_x_nm, scan_y_nm;         // located in the fresh scan
    // A particle: the distance between the two. A wire: the centroid distance
    // plus half its length times |sin(axis angle error)|, a bound on how far
    // the ends of the rigid motion between the two images move.
    double error_nm;
    bool found;                          // the scan shows the object there at all
    // Wires only: the centroid distance and the axis angles (principal axis
    // of the imaged ridge, degrees from +x, in [0, 180)).
    double centroid_error_nm = 0;
    double display_angle_deg = 0, scan_angle_deg = 0;
    double angle_error_deg = 0;          // scan - display, in [-90, 90)
};

struct Fidelity {
    double max_position_error_nm = 0;
    double max_angle_error_deg = 0;      // over the wires, absolute
    double rms_height_error_nm = 0;
    std::vector<ObjectFidelity> objects;
    cv::Mat diff_nm;                     // displayed - scan, nm (CV_32F)
};

// `search_nm`: how far from the model position an object is looked for.
Fidelity compare_with_scan(const cv::Mat &displayed_nm, const cv::Mat &scan_nm, const Field &f, const DisplayModel &model,
                           const TipShape &tip, double search_nm);
// The same with particles only.
Fidelity compare_with_scan(const cv::Mat &displayed_nm, const cv::Mat &scan_nm, const Field &f,
                           const std::vector<DisplayObject> &model, const TipShape &tip, double search_nm);

// Locates a bump near (x, y): height-weighted centroid of the pixels above
// half the window's peak. Returns false if the window holds no bump.
bool locate_bump(const cv::Mat &h_nm, const Field &f, double x_nm, double y_nm, double radius_nm, double *cx, double *cy);

// locate_bump `passes` times, each window centred on what the last found:
// a window that cut the bump off at one side pulls the centroid towards its
// own centre; centred again, it does not.
bool locate_bump_centred(const cv::Mat &h_nm, const Field &f, double x_nm, double y_nm, double radius_nm, int passes, double *cx,
                         double *cy);

// The bump (a region higher than min_height_nm) whose centre is nearest
// (x, y), leaving out any centred within skip_nm of one of `others` (other
// objects where the model has them); located then as locate_bump_centred
// with a window of radius_nm. False if the image holds none.
bool nearest_bump(const cv::Mat &h_nm, const Field &f, double x_nm, double y_nm, double min_height_nm, double radius_nm,
                  const std::vector<cv::Point2d> &others, double skip_nm, double *cx, double *cy);

// The planner's result against a fresh scan: for each target site (where
// it is in frame A now), the particle the scan shows within search_nm of it
// (located as locate_bump_centred); placed when within tolerance_nm.
struct SiteCheck {
    double x_nm, y_nm;              // the site, frame A
    bool found = false;
    double scan_x_nm = 0, scan_y_nm = 0;
    double error_nm = 0;            // found: the distance
};
struct SitesCheck {
    std::vector<SiteCheck> sites;
    int placed = 0;                 // found within the tolerance
    double worst_nm = 0, rms_nm = 0;   // over the sites found
    int missing = 0;                // no particle found near the site
};
SitesCheck check_sites(const cv::Mat &scan_nm, const Field &f, const std::vector<cv::Point2d> &sites_nm, double search_nm,
                           double tolerance_nm);

// A rod against its target pose in a fresh scan: the ridge within band_nm
// of the target's axis; error as compare_with_scan's for wires (centroid
// distance plus half the length times |sin(angle error)|).
struct RodCheck {
    bool found = false;
    double centroid_error_nm = 0, angle_error_deg = 0, error_nm = 0;
};
RodCheck check_rod(const cv::Mat &scan_nm, const Field &f, cv::Point2d centre_nm, double angle_deg, double length_nm, double band_nm);

// Locates a ridge (a wire) within band_nm of a polyline: the rise-weighted
// centroid and principal axis (radians from +x, in [0, pi)) of the pixels of
// that band whose rise is above half its peak. The rise is a pixel's height
// above the ground beside it across the nearest segment's axis (the image
// less its opening by a line of half-length band_nm across that axis: 0 on
// the flat substrate, on a groove's walls and at a groove's end, so a wire
// lying on the flat and one seated in a groove below the surface are found
// alike, and the end of a seated rod does not outweigh its length). Returns
// false if the band holds no ridge.
bool locate_ridge(const cv::Mat &h_nm, const Field &f, const std::vector<cv::Point2d> &nodes_nm, double band_nm,
                  double *cx, double *cy, double *angle_rad);

// Diverging colour image of a difference (blue negative, red positive, white 0).
cv::Mat diff_image(const cv::Mat &diff_nm, double range_nm);

}  // namespace afm
