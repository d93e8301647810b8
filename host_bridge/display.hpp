// The videolized display, without the bus: the last scan as background, the
// modelled objects drawn on it with the profile a scan would show, updated
// locally (only the footprints that moved), colourised with a colour bar and
// a scale bar, and the tip and force overlaid. The renderer process and
// ./afm bench render both use it.
#pragma once

#include <opencv2/core.hpp>

#include <map>
#include <string>
#include <vector>

#include "profile.hpp"

namespace afm {

struct DisplayObject {        // a particle as the display knows it (model frame A, nm)
    int id;
    double x_nm, y_nm, radius_nm;
};

struct Field {                // the imaged square
    double x0_nm, y0_nm;      // lower-left corner, frame A
    double size_nm;           // side
    int px;                   // pixels per side
    double pitch() const { return size_nm / px; }
    // Pixel (col, row; row 0 at the top) of a point, as doubles (pixel centres at .0).
    cv::Point2d to_px(double x, double y) const
    {
        return {(x - x0_nm) / pitch() - 0.5, px - 1 - ((y - y0_nm) / pitch() - 0.5)};
    }
    double x_of(int col) const { return x0_nm + (col + 0.5) * pitch(); }
    double y_of(int row) const { return y0_nm + (px - 1 - row + 0.5) * pitch(); }
};

struct Overlay {              // what is drawn over the image in one frame
    double t_s = 0;
    double tip_nm[2] = {0, 0};
    double force_nN[3] = {0, 0, 0};
    int flags = 0;            // fw_force_t FLAG_* bits
};

class Display {
public:
    Display(const Field &f, const TipShape &tip);

    // Background: a scan (heights, nm, CV_32F, row 0 at the top). The objects
    // the model knows are erased from it (the substrate, flat, lies under them)
    // and drawn again from the model.
    void start(const cv::Mat &scan_nm, const std::vector<DisplayObject> &objects);
    // Local update: restores and redraws only the footprints that moved.
    // Returns the number of pixels touched.
    long update(const std::vector<DisplayObject> &objects);
    // Full redraw of every object (the reference for ./afm bench render).
    long redraw(const std::vector<DisplayObject> &objects);
    // Replaces a region of the background and of the image by a local scan.
    void paste_scan(const cv::Mat &scan_nm, const cv::Rect &where);

    // Trails: past positions drawn as faint markers (the paper's fig. 18d).
    void set_trails(bool on) { trails_ = on; }

    const cv::Mat &height() const { return height_; }     // nm, CV_32F
    double z_top() const { return z_top_; }
    // The frame: colourised heights, colour bar, scale bar, tip, force, flags.
    cv::Mat frame(const Overlay &o) const;
    // Colourise heights with the display's colour map and scale.
    cv::Mat colourise(const cv::Mat &h_nm) const;
    const Field &field() const { return f_; }

    cv::Rect footprint(const DisplayObject &p) const;

private:
    void draw(cv::Mat &img, const DisplayObject &p, const cv::Rect &clip) const;
    void colourise_into(const cv::Rect &r);

    Field f_;
    TipShape tip_;
    double z_top_ = 1;
    cv::Mat base_, height_, colour_;
    cv::Mat lut_;
    std::map<int, DisplayObject> drawn_;
    std::vector<cv::Point2d> trail_pts_;
    bool trails_ = false;
};

// Writes a Gwyddion Simple Field (.gsf) file: heights in nm -> metres, the
// field's physical size, units m. Returns false (and sets *err) on failure.
bool write_gsf(const std::string &path, const cv::Mat &h_nm, const Field &f, const std::string &title, std::string *err);

// A grid of frames in one image (at most `cols` per row).
cv::Mat contact_sheet(const std::vector<cv::Mat> &frames, int cols);

}  // namespace afm
