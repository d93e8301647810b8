// The videolized display, without the bus: the last scan as background, the
// modelled objects (particles, wires, lithography trenches) drawn on it with
// the profile a scan would show, updated locally (only the footprints that
// moved), colourised with a colour bar and a scale bar, and the tip and force
// overlaid. The renderer process and ./afm bench render both use it.
#pragma once

#include <opencv2/core.hpp>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "profile.hpp"

namespace afm {

struct DisplayObject {        // a particle as the display knows it (model frame A, nm)
    int id;
    double x_nm, y_nm, radius_nm;
};

struct DisplayWire {          // a wire: a cylinder of diameter d lying along a polyline (2 nodes: a rigid rod)
    int id;
    double diameter_nm;
    std::vector<cv::Point2d> nodes_nm;   // frame A, nm
    double sink_nm = 0;                  // how far its axis lies below d/2 (seated in a groove: the card's axis_z), nm
};

struct TrenchPoint {          // a point of a trench's path (frame A, nm)
    double x_nm, y_nm;
    double depth_nm;          // below the substrate, positive
    double width_nm;          // at the surface
};

struct DisplayTrench {        // a lithography V-groove along a polyline, depth and width linear between points
    int id;
    std::vector<TrenchPoint> points;
};

struct DisplayModel {         // every object the model knows; ids are per kind
    std::vector<DisplayObject> particles;
    std::vector<DisplayWire> wires;
    std::vector<DisplayTrench> trenches;
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

// The words a frame writes for a block's flags (fw_state_t FLAG_*), each
// followed by a space ("" for none): the one list, for the display's frame
// and the renderer's overlay.
std::string flag_words(int flags);

struct Overlay {              // what is drawn over the image in one frame
    double t_s = 0;
    double tip_nm[2] = {0, 0};
    double force_nN[3] = {0, 0, 0};
    int flags = 0;            // fw_state_t FLAG_* bits
    // The force the operator's hand feels (HAPTIC_FORCE, N, frame A axes),
    // drawn as an arrow in a circle of hand_scale_N; none when that is 0.
    double hand_N[2] = {0, 0};
    double hand_scale_N = 0;
};

class Display {
public:
    Display(const Field &f, const TipShape &tip);

    // Background: a scan (heights, nm, CV_32F, row 0 at the top). The objects
    // the model knows are erased from it (the substrate, flat, lies under them)
    // and drawn again from the model. The colour scale spans the scan, the
    // model's objects and the substrate level 0.
    void start(const cv::Mat &scan_nm, const DisplayModel &model);
    // Local update: restores and redraws only the footprints that moved (for a
    // trench, the part of its path that changed); objects no longer in the
    // model are erased. Pixel-identical to redraw() of the same model. Returns
    // the number of pixels touched.
    long update(const DisplayModel &model);
    // Full redraw of every object (the reference for ./afm bench render).
    long redraw(const DisplayModel &model);
    // The same with particles only.
    void start(const cv::Mat &scan_nm, const std::vector<DisplayObject> &particles) { start(scan_nm, DisplayModel{particles, {}, {}}); }
    long update(const std::vector<DisplayObject> &particles) { return update(DisplayModel{particles, {}, {}}); }
    long redraw(const std::vector<DisplayObject> &particles) { return redraw(DisplayModel{particles, {}, {}}); }
    // The whole sample moved by (dx, dy) nm (a re-registration after a
    // cantilever change): the background moves with it; what enters at the
    // edges is substrate (0). Redraws everything.
    void shift_background(double dx_nm, double dy_nm);
    // Replaces a region of the background and of the image by a local scan.
    void paste_scan(const cv::Mat &scan_nm, const cv::Rect &where);

    // Trails: past positions drawn as faint markers (the paper's fig. 18d).
    void set_trails(bool on) { trails_ = on; }
    // The trails' points (display pixels), for a frame composed elsewhere (renderer/frame_overlay.hpp).
    const std::vector<cv::Point2d> &trail_points() const { return trail_pts_; }

    const cv::Mat &height() const { return height_; }     // nm, CV_32F
    // height() colourised (colourise), kept pixel for pixel as height() changes:
    // every write to the heights recolours its rectangle, a rescale the whole.
    const cv::Mat &colour() const { return colour_; }     // CV_8UC3, BGR
    double z_top() const { return z_top_; }               // colour scale: heights at the top and
    double z_bottom() const { return z_bot_; }            // the bottom of the colour bar, nm
    // The frame: colourised heights, colour bar, scale bar, tip, force, flags.
    cv::Mat frame(const Overlay &o) const;
    // Colourise heights with the display's colour map and scale.
    cv::Mat colourise(const cv::Mat &h_nm) const;
    const Field &field() const { return f_; }

    // Pixels an object's image can touch (bounding box, clipped to the field).
    cv::Rect footprint(const DisplayObject &p) const;
    cv::Rect footprint(const DisplayWire &w) const;
    cv::Rect footprint(const DisplayTrench &t) const;

private:
    cv::Rect box_px(double xlo, double ylo, double xhi, double yhi) const;
    cv::Rect segment_box(const cv::Point2d &a, const cv::Point2d &b, double reach_nm) const;
    cv::Rect trench_piece_box(const DisplayTrench &t, std::size_t i) const;
    cv::Rect trench_changed_box(const DisplayTrench &t, std::size_t from) const;
    void draw(cv::Mat &img, const DisplayObject &p, const cv::Rect &clip) const;
    void draw(cv::Mat &img, const DisplayWire &w, const cv::Rect &clip) const;
    void carve(cv::Mat &img, const DisplayTrench &t, const cv::Rect &clip) const;
    void erase_footprints(cv::Mat &img, const cv::Rect &clip) const;
    void render(const cv::Rect &r);
    void set_drawn(const DisplayModel &m);
    bool fit_range(const DisplayModel &m);
    void colourise_into(const cv::Rect &r);

    Field f_;
    TipShape tip_;
    double z_top_ = 1, z_bot_ = 0;
    cv::Mat base_, height_, colour_;
    cv::Mat lut_;
    cv::Mat colour_bar_;   // the colour bar's gradient (frame()), made once
    std::map<int, DisplayObject> drawn_;
    std::map<int, DisplayWire> wires_;
    std::map<int, DisplayTrench> trenches_;
    std::vector<cv::Point2d> trail_pts_;
    bool trails_ = false;
};

// What a GSF file carries besides its grid: extra "Key = value" header lines
// (the run's metadata; keys without spaces, '=' or line breaks, values
// without line breaks), and the values' unit: heights in nm written in m
// (scale 1e-9, "m"), or a signal as it is (the lateral S_l: 1, "V").
struct GsfMeta {
    std::vector<std::pair<std::string, std::string>> keys;
    double scale = 1e-9;
    std::string z_units = "m";
};

// Writes a Gwyddion Simple Field (.gsf) file (the format: common/gsf.hpp): heights in nm -> metres, the
// field's physical size, units m. Returns false (and sets *err) on failure.
bool write_gsf(const std::string &path, const cv::Mat &h_nm, const Field &f, const std::string &title, std::string *err);
// The same for a part of the field: `region` in the field's pixels (row 0 at
// the top), h_nm its heights; `meta`: extra keys and the values' unit.
bool write_gsf(const std::string &path, const cv::Mat &h_nm, const Field &f, const cv::Rect &region, const std::string &title,
               std::string *err, const GsfMeta &meta = GsfMeta{});

// A grid of frames in one image (at most `cols` per row).
cv::Mat contact_sheet(const std::vector<cv::Mat> &frames, int cols);

}  // namespace afm
