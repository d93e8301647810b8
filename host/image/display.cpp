#include "display.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <utility>

#include "afm/fw_state_t.hpp"
#include "gsf.hpp"

namespace afm {

namespace {

// matplotlib's afmhot, the usual AFM height colour map (BGR).
cv::Mat afmhot_lut()
{
    cv::Mat lut(1, 256, CV_8UC3);
    for (int i = 0; i < 256; ++i) {
        const double x = i / 255.0;
        auto c = [](double v) { return static_cast<uchar>(std::lround(255 * std::clamp(v, 0.0, 1.0))); };
        lut.at<cv::Vec3b>(0, i) = cv::Vec3b(c(2 * x - 1), c(2 * x - 0.5), c(2 * x));
    }
    return lut;
}

constexpr double kForceArrowPxPerNn = 20.0;   // overlay scale of the force arrow
constexpr double kRangeMargin = 1.1;           // colour scale at start: 10 % beyond the highest and deepest heights
constexpr double kRangeGrowth = 1.25;          // widened by 25 % beyond an object that leaves it

// Text legible on any colour of the map: a dark outline under it. The text
// is drawn once, thin and anti-aliased, into a coverage mask around it; its
// outline is that mask dilated by a pixel (the width of cv::putText's
// 3-pixel stroke). Both are blended into the BGR frame: the outline towards
// black, then the text towards its colour. Drawing the outline as 3-pixel
// anti-aliased strokes (cv::putText) cost many times the thin text, and
// most of a frame's composing (./afm bench render times the composing).
void put_label(cv::Mat &img, const std::string &text, cv::Point org, double scale, const cv::Scalar &colour)
{
    CV_Assert(img.type() == CV_8UC3);
    int baseline = 0;
    const cv::Size sz = cv::getTextSize(text, cv::FONT_HERSHEY_PLAIN, scale, 1, &baseline);
    // room for strokes above the cap height ('|'), the descenders, the outline
    const int pad = 3, above = sz.height / 2 + pad;
    const cv::Rect box(org.x - pad, org.y - sz.height - above, sz.width + 2 * pad, sz.height + above + baseline + pad);
    const cv::Rect on = box & cv::Rect(0, 0, img.cols, img.rows);
    if (on.empty()) return;
    cv::Mat text_a = cv::Mat::zeros(box.size(), CV_8U), outline_a;
    cv::putText(text_a, text, org - box.tl(), cv::FONT_HERSHEY_PLAIN, scale, cv::Scalar(255), 1, cv::LINE_AA);
    cv::dilate(text_a, outline_a, cv::Mat());
    const int c[3] = {cv::saturate_cast<uchar>(colour[0]), cv::saturate_cast<uchar>(colour[1]), cv::saturate_cast<uchar>(colour[2])};
    for (int y = on.y; y < on.br().y; ++y) {
        cv::Vec3b *px = img.ptr<cv::Vec3b>(y) + on.x;
        const uchar *t = text_a.ptr<uchar>(y - box.y) + (on.x - box.x);
        const uchar *o = outline_a.ptr<uchar>(y - box.y) + (on.x - box.x);
        for (int x = 0; x < on.width; ++x) {
            if (!o[x]) continue;
            for (int k = 0; k < 3; ++k) {
                const int under = (px[x][k] * (255 - o[x]) + 127) / 255;
                px[x][k] = static_cast<uchar>(under + ((c[k] - under) * t[x] + (c[k] >= under ? 127 : -127)) / 255);
            }
        }
    }
}

// Union of two pixel rectangles, either possibly empty.
cv::Rect unite(const cv::Rect &a, const cv::Rect &b)
{
    if (a.area() == 0) return b;
    if (b.area() == 0) return a;
    return a | b;
}

// Distance from q to the segment a-b; *t_out (optional): the closest point's
// parameter in [0, 1].
double segment_distance(const cv::Point2d &a, const cv::Point2d &b, const cv::Point2d &q, double *t_out)
{
    const cv::Point2d ab = b - a;
    const double l2 = ab.dot(ab);
    const double t = l2 > 0 ? std::clamp((q - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
    if (t_out) *t_out = t;
    return std::hypot(q.x - a.x - t * ab.x, q.y - a.y - t * ab.y);
}

cv::Point2d centroid(const std::vector<cv::Point2d> &pts)
{
    cv::Point2d c(0, 0);
    for (const auto &p : pts) c += p;
    return c * (1.0 / static_cast<double>(pts.size()));
}

bool same_wire(const DisplayWire &a, const DisplayWire &b)
{
    return a.diameter_nm == b.diameter_nm && a.nodes_nm == b.nodes_nm && a.sink_nm == b.sink_nm;
}

// Index of the first point where two versions of a trench differ (the
// shorter one's length if one extends the other).
std::size_t first_difference(const DisplayTrench &a, const DisplayTrench &b)
{
    const std::size_t n = std::min(a.points.size(), b.points.size());
    for (std::size_t i = 0; i < n; ++i) {
        const TrenchPoint &p = a.points[i], &q = b.points[i];
        if (p.x_nm != q.x_nm || p.y_nm != q.y_nm || p.depth_nm != q.depth_nm || p.width_nm != q.width_nm) return i;
    }
    return n;
}

// The model's highest object top and deepest trench, nm (both >= 0).
std::pair<double, double> model_extent(const DisplayModel &m)
{
    double top = 0, deep = 0;
    for (const auto &p : m.particles) top = std::max(top, 2 * p.radius_nm);
    for (const auto &w : m.wires) top = std::max(top, w.diameter_nm);
    for (const auto &t : m.trenches)
        for (const auto &p : t.points) deep = std::max(deep, p.depth_nm);
    return {top, deep};
}
const cv::Scalar kWhite(255, 255, 255), kCyan(255, 255, 0), kTip(255, 200, 0), kYellow(0, 255, 255), kRed(0, 0, 255);

// The force interlock's mark (FLAG_INTERLOCK): a red border round the whole
// frame and a red banner under the flags' line, "INTERLOCK: TIP RETRACTED"
// (shorter on a narrow frame), drawn last so nothing covers it.
void draw_interlock(cv::Mat &img)
{
    const int N = img.cols, M = img.rows, t = std::max(2, N / 128);
    for (const cv::Rect &edge : {cv::Rect(0, 0, N, t), cv::Rect(0, M - t, N, t), cv::Rect(0, 0, t, M), cv::Rect(N - t, 0, t, M)})
        cv::rectangle(img, edge, kRed, cv::FILLED);
    const cv::Rect bar(t, 28, N - 2 * t, 14);
    cv::rectangle(img, bar, kRed, cv::FILLED);
    // the longest wording that fits the frame's width
    for (const char *text : {"INTERLOCK: TIP RETRACTED", "INTERLOCK: RETRACTED", "INTERLOCK"}) {
        int base = 0;
        if (cv::getTextSize(text, cv::FONT_HERSHEY_PLAIN, 0.8, 1, &base).width <= bar.width - 6 || text[9] == '\0') {
            cv::putText(img, text, cv::Point(bar.x + 3, bar.y + 11), cv::FONT_HERSHEY_PLAIN, 0.8, kWhite, 1, cv::LINE_AA);
            break;
        }
    }
}

// Where frame() draws the colour bar (height, nm): a strip at the right
// edge, 30 px in from it and from the top and bottom; empty in a frame too
// small for one.
cv::Rect colour_bar_box(int N)
{
    const int bw = std::max(4, N / 40);
    const cv::Rect r(N - bw - 30, 30, bw + 1, N - 59);
    return r.height > 21 ? r : cv::Rect();
}

// The colour bar's gradient, drawn once: white (z_top) at the top row, black
// (z_bottom) at the bottom row.
cv::Mat colour_bar(const cv::Mat &lut, cv::Size size)
{
    cv::Mat bar(size, CV_8UC3);
    for (int y = 0; y < bar.rows; ++y) bar.row(y).setTo(lut.at<cv::Vec3b>(0, cvRound(255.0 * (bar.rows - 1 - y) / (bar.rows - 1))));
    return bar;
}

}  // namespace

Display::Display(const Field &f, const TipShape &tip) : f_(f), tip_(tip), lut_(afmhot_lut())
{
    const cv::Rect bar = colour_bar_box(f_.px);
    if (!bar.empty()) colour_bar_ = colour_bar(lut_, bar.size());
}

cv::Rect Display::box_px(double xlo, double ylo, double xhi, double yhi) const
{
    const cv::Point2d lo = f_.to_px(xlo, yhi), hi = f_.to_px(xhi, ylo);
    const int c0 = static_cast<int>(std::floor(lo.x)), r0 = static_cast<int>(std::floor(lo.y));
    const int c1 = static_cast<int>(std::ceil(hi.x)), r1 = static_cast<int>(std::ceil(hi.y));
    return cv::Rect(c0, r0, c1 - c0 + 1, r1 - r0 + 1) & cv::Rect(0, 0, f_.px, f_.px);
}

cv::Rect Display::footprint(const DisplayObject &p) const
{
    const double r = sphere_footprint_nm(p.radius_nm, tip_) + f_.pitch();
    return box_px(p.x_nm - r, p.y_nm - r, p.x_nm + r, p.y_nm + r);
}

cv::Rect Display::segment_box(const cv::Point2d &a, const cv::Point2d &b, double reach_nm) const
{
    const double r = reach_nm + f_.pitch();
    return box_px(std::min(a.x, b.x) - r, std::min(a.y, b.y) - r, std::max(a.x, b.x) + r, std::max(a.y, b.y) + r);
}

cv::Rect Display::footprint(const DisplayWire &w) const
{
    cv::Rect r;
    const double reach = wire_footprint_nm(0.5 * w.diameter_nm, tip_);
    for (std::size_t i = 0; i < w.nodes_nm.size(); ++i) r = unite(r, segment_box(w.nodes_nm[i], w.nodes_nm[i], reach));
    return r;
}

// Piece i of a trench: the groove around point i and along the segment from
// point i - 1 to it.
cv::Rect Display::trench_piece_box(const DisplayTrench &t, std::size_t i) const
{
    const TrenchPoint &b = t.points[i], &a = t.points[i > 0 ? i - 1 : i];
    return segment_box({a.x_nm, a.y_nm}, {b.x_nm, b.y_nm}, 0.5 * std::max(a.width_nm, b.width_nm));
}

cv::Rect Display::trench_changed_box(const DisplayTrench &t, std::size_t from) const
{
    cv::Rect r;
    for (std::size_t i = from; i < t.points.size(); ++i) r = unite(r, trench_piece_box(t, i));
    return r;
}

cv::Rect Display::footprint(const DisplayTrench &t) const { return trench_changed_box(t, 0); }

std::string flag_words(int flags)
{
    std::string w;
    if (flags & fw_state_t::FLAG_CONTACT) w += "PUSH ";
    if (flags & (fw_state_t::FLAG_SAT_SN | fw_state_t::FLAG_SAT_SL)) w += "SATURATED ";
    if (flags & fw_state_t::FLAG_FX_UNOBSERVABLE) w += "Fx-FALLBACK ";
    if (flags & fw_state_t::FLAG_SQUEEZE) w += "SQUEEZE ";
    if (flags & fw_state_t::FLAG_RIDEOVER) w += "RIDE-OVER ";
    if (flags & fw_state_t::FLAG_INTERLOCK) w += "INTERLOCK ";
    return w;
}

void Display::draw(cv::Mat &img, const DisplayObject &p, const cv::Rect &clip) const
{
    const cv::Rect r = footprint(p) & clip;
    for (int row = r.y; row < r.y + r.height; ++row) {
        float *dst = img.ptr<float>(row);
        const double y = f_.y_of(row);
        for (int col = r.x; col < r.x + r.width; ++col) {
            const double z = sphere_profile_nm(p.radius_nm, std::hypot(f_.x_of(col) - p.x_nm, y - p.y_nm), tip_);
            if (z > 0 && z > dst[col]) dst[col] = static_cast<float>(z);
        }
    }
}

void Display::draw(cv::Mat &img, const DisplayWire &w, const cv::Rect &clip) const
{
    // Segment by segment: the profile falls with the distance from the axis,
    // so the largest over the segments is the profile at the polyline's
    // distance, whatever the order.
    const double R = 0.5 * w.diameter_nm, reach = wire_footprint_nm(R, tip_);
    const std::size_t n = w.nodes_nm.size(), segments = n > 1 ? n - 1 : n;   // one node: a sphere-capped point
    for (std::size_t i = 0; i < segments; ++i) {
        const cv::Point2d a = w.nodes_nm[i], b = w.nodes_nm[std::min(i + 1, n - 1)];
        const cv::Rect r = segment_box(a, b, reach) & clip;
        for (int row = r.y; row < r.y + r.height; ++row) {
            float *dst = img.ptr<float>(row);
            const double y = f_.y_of(row);
            for (int col = r.x; col < r.x + r.width; ++col) {
                const double z = wire_profile_nm(R, segment_distance(a, b, {f_.x_of(col), y}, nullptr), tip_);
                if (z > 0 && z - w.sink_nm > dst[col]) dst[col] = static_cast<float>(z - w.sink_nm);   // a sunk rod over its groove
            }
        }
    }
}

void Display::carve(cv::Mat &img, const DisplayTrench &t, const cv::Rect &clip) const
{
    // The groove around each point and along each segment (depth and width
    // linear along it); the deepest wins, whatever the order.
    for (std::size_t i = 0; i < t.points.size(); ++i) {
        const cv::Rect r = trench_piece_box(t, i) & clip;
        if (r.area() == 0) continue;
        const TrenchPoint &b = t.points[i], &a = t.points[i > 0 ? i - 1 : i];
        const cv::Point2d pa(a.x_nm, a.y_nm), pb(b.x_nm, b.y_nm);
        for (int row = r.y; row < r.y + r.height; ++row) {
            float *dst = img.ptr<float>(row);
            const double y = f_.y_of(row);
            for (int col = r.x; col < r.x + r.width; ++col) {
                const cv::Point2d q(f_.x_of(col), y);
                double z = groove_profile_nm(b.depth_nm, 0.5 * b.width_nm, std::hypot(q.x - pb.x, q.y - pb.y), tip_);
                if (i > 0) {
                    double s;
                    const double u = segment_distance(pa, pb, q, &s);
                    z = std::max(z, groove_profile_nm((1 - s) * a.depth_nm + s * b.depth_nm,
                                                      0.5 * ((1 - s) * a.width_nm + s * b.width_nm), u, tip_));
                }
                if (z > 0) dst[col] = std::min(dst[col], static_cast<float>(-z));
            }
        }
    }
}

void Display::erase_footprints(cv::Mat &img, const cv::Rect &clip) const
{
    // The substrate, flat at 0, under every object the model draws.
    for (const auto &kv : drawn_) img(footprint(kv.second) & clip).setTo(0.0f);
    for (const auto &kv : wires_) {
        const auto &w = kv.second;
        const double reach = wire_footprint_nm(0.5 * w.diameter_nm, tip_);
        const std::size_t n = w.nodes_nm.size(), segments = n > 1 ? n - 1 : n;
        for (std::size_t i = 0; i < segments; ++i) img(segment_box(w.nodes_nm[i], w.nodes_nm[std::min(i + 1, n - 1)], reach) & clip).setTo(0.0f);
    }
    for (const auto &kv : trenches_)
        for (std::size_t i = 0; i < kv.second.points.size(); ++i) img(trench_piece_box(kv.second, i) & clip).setTo(0.0f);
}

void Display::colourise_into(const cv::Rect &r)
{
    if (r.area() > 0) colourise(height_(r)).copyTo(colour_(r));
}

cv::Mat Display::colourise(const cv::Mat &h_nm) const
{
    cv::Mat u8, bgr;
    const double scale = 255.0 / (z_top_ - z_bot_);
    h_nm.convertTo(u8, CV_8U, scale, -z_bot_ * scale);
    cv::cvtColor(u8, bgr, cv::COLOR_GRAY2BGR);
    cv::LUT(bgr, lut_, bgr);
    return bgr;
}

void Display::set_drawn(const DisplayModel &m)
{
    drawn_.clear();
    wires_.clear();
    trenches_.clear();
    for (const auto &p : m.particles) drawn_[p.id] = p;
    for (const auto &w : m.wires) wires_[w.id] = w;
    for (const auto &t : m.trenches) trenches_[t.id] = t;
}

bool Display::fit_range(const DisplayModel &m)
{
    // Widens the colour scale (never narrows it: the colours of the pixels
    // not redrawn stay valid) when an object leaves it.
    const auto [top, deep] = model_extent(m);
    bool changed = false;
    if (top > z_top_) {
        z_top_ = kRangeGrowth * top;
        changed = true;
    }
    if (-deep < z_bot_) {
        z_bot_ = -kRangeGrowth * deep;
        changed = true;
    }
    return changed;
}

void Display::render(const cv::Rect &r)
{
    if (r.area() == 0) return;
    base_(r).copyTo(height_(r));
    for (const auto &kv : trenches_) carve(height_, kv.second, r);
    for (const auto &kv : wires_) draw(height_, kv.second, r);
    for (const auto &kv : drawn_) draw(height_, kv.second, r);
    colourise_into(r);
}

void Display::start(const cv::Mat &scan_nm, const DisplayModel &model)
{
    double zmin, zmax;
    cv::minMaxLoc(scan_nm, &zmin, &zmax);
    const auto [top, deep] = model_extent(model);
    z_top_ = std::max(1.0, kRangeMargin * std::max(zmax, top));
    z_bot_ = std::min(0.0, kRangeMargin * std::min(zmin, -deep));
    base_ = scan_nm.clone();
    set_drawn(model);
    erase_footprints(base_, cv::Rect(0, 0, f_.px, f_.px));
    height_ = cv::Mat(f_.px, f_.px, CV_32F);
    colour_ = cv::Mat(f_.px, f_.px, CV_8UC3);
    render(cv::Rect(0, 0, f_.px, f_.px));
}

long Display::redraw(const DisplayModel &model)
{
    set_drawn(model);
    fit_range(model);
    const cv::Rect all(0, 0, f_.px, f_.px);
    render(all);
    return static_cast<long>(all.area());
}

long Display::update(const DisplayModel &model)
{
    std::vector<cv::Rect> dirty;
    // Particles and wires: the old and the new footprint of each that moved.
    std::map<int, bool> seen;
    for (const auto &p : model.particles) {
        seen[p.id] = true;
        auto it = drawn_.find(p.id);
        if (it != drawn_.end() && it->second.x_nm == p.x_nm && it->second.y_nm == p.y_nm && it->second.radius_nm == p.radius_nm)
            continue;
        cv::Rect r = footprint(p);
        if (it != drawn_.end()) {
            r = unite(r, footprint(it->second));
            if (trails_) trail_pts_.push_back(f_.to_px(it->second.x_nm, it->second.y_nm));
        }
        dirty.push_back(r);
    }
    for (const auto &kv : drawn_)
        if (!seen.count(kv.first)) dirty.push_back(footprint(kv.second));
    seen.clear();
    for (const auto &w : model.wires) {
        seen[w.id] = true;
        auto it = wires_.find(w.id);
        if (it != wires_.end() && same_wire(it->second, w)) continue;
        cv::Rect r = footprint(w);
        if (it != wires_.end()) {
            r = unite(r, footprint(it->second));
            if (trails_ && !it->second.nodes_nm.empty()) {
                const cv::Point2d c = centroid(it->second.nodes_nm);
                trail_pts_.push_back(f_.to_px(c.x, c.y));
            }
        }
        dirty.push_back(r);
    }
    for (const auto &kv : wires_)
        if (!seen.count(kv.first)) dirty.push_back(footprint(kv.second));
    // Trenches: the pieces from the first point that changed (a trench being
    // cut grows at its end).
    seen.clear();
    for (const auto &t : model.trenches) {
        seen[t.id] = true;
        auto it = trenches_.find(t.id);
        if (it == trenches_.end()) {
            dirty.push_back(footprint(t));
            continue;
        }
        const std::size_t k = first_difference(it->second, t);
        if (k == t.points.size() && k == it->second.points.size()) continue;
        dirty.push_back(unite(trench_changed_box(t, k), trench_changed_box(it->second, k)));
    }
    for (const auto &kv : trenches_)
        if (!seen.count(kv.first)) dirty.push_back(footprint(kv.second));

    set_drawn(model);
    const bool rescaled = fit_range(model);
    long touched = 0;
    for (const cv::Rect &r : dirty) {
        render(r);
        touched += r.area();
    }
    if (rescaled) colourise_into(cv::Rect(0, 0, f_.px, f_.px));
    return touched;
}

void Display::shift_background(double dx_nm, double dy_nm)
{
    // Image rows run downwards: +y in frame A is -row.
    const cv::Mat t = (cv::Mat_<double>(2, 3) << 1, 0, dx_nm / f_.pitch(), 0, 1, -dy_nm / f_.pitch());
    cv::Mat moved;
    cv::warpAffine(base_, moved, t, base_.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
    base_ = moved;
    render(cv::Rect(0, 0, f_.px, f_.px));
}

void Display::paste_scan(const cv::Mat &scan_nm, const cv::Rect &where)
{
    const cv::Rect r = where & cv::Rect(0, 0, f_.px, f_.px);
    scan_nm(cv::Rect(r.x - where.x, r.y - where.y, r.width, r.height)).copyTo(height_(r));
    // The background under the objects there is what the local scan shows
    // with the modelled objects erased.
    height_(r).copyTo(base_(r));
    erase_footprints(base_, r);
    colourise_into(r);
}

cv::Mat Display::frame(const Overlay &o) const
{
    cv::Mat img = colour_.clone();
    const int N = f_.px;
    for (const auto &p : trail_pts_) cv::circle(img, cv::Point(cvRound(p.x), cvRound(p.y)), 1, cv::Scalar(120, 120, 120), cv::FILLED);
    // Tip and the measured lateral force on it.
    const cv::Point2d tp = f_.to_px(o.tip_nm[0], o.tip_nm[1]);
    const cv::Point t(cvRound(tp.x), cvRound(tp.y));
    cv::circle(img, t, 3, kTip, 1, cv::LINE_AA);
    const cv::Point fv(cvRound(o.force_nN[0] * kForceArrowPxPerNn), cvRound(-o.force_nN[1] * kForceArrowPxPerNn));
    if (fv.x || fv.y) cv::arrowedLine(img, t, t + fv, kCyan, 1, cv::LINE_AA, 0, 0.2);
    // Text: time, force magnitude, flags.
    char text[128];
    std::snprintf(text, sizeof text, "t %.2f s  |F| %.2f nN", o.t_s, std::hypot(o.force_nN[0], o.force_nN[1]));
    put_label(img, text, cv::Point(4, 12), 0.8, kWhite);
    const std::string flags = flag_words(o.flags);
    if (!flags.empty()) put_label(img, flags, cv::Point(4, 24), 0.8, kYellow);
    // The hand's gauge, bottom middle (right of the scale bar): a circle of
    // hand_scale_N, an arrow for the force on the stylus (at most twice out).
    if (o.hand_scale_N > 0) {
        const int rad = std::max(8, N / 16);
        const cv::Point c(N / 2 + rad, N - rad - 16);
        cv::circle(img, c, rad, kWhite, 1, cv::LINE_AA);
        const double k = rad / o.hand_scale_N;
        const cv::Point hv(cvRound(std::clamp(o.hand_N[0] * k, -2.0 * rad, 2.0 * rad)), cvRound(std::clamp(-o.hand_N[1] * k, -2.0 * rad, 2.0 * rad)));
        if (hv.x || hv.y) cv::arrowedLine(img, c, c + hv, kYellow, 1, cv::LINE_AA, 0, 0.25);
        std::snprintf(text, sizeof text, "hand %.3f N (o %.2g)", std::hypot(o.hand_N[0], o.hand_N[1]), o.hand_scale_N);
        put_label(img, text, cv::Point(N / 2, N - 4), 0.7, kYellow);
    }
    // Colour bar (height, nm) at the right edge.
    if (const cv::Rect bar = colour_bar_box(N); !bar.empty()) {
        const int bw = bar.width - 1, bx = bar.x, by0 = bar.y, by1 = bar.br().y - 1;
        colour_bar_.copyTo(img(bar));
        cv::rectangle(img, cv::Point(bx - 1, by0 - 1), cv::Point(bx + bw + 1, by1 + 1), kWhite);
        std::snprintf(text, sizeof text, "%.0f", z_top_);
        put_label(img, text, cv::Point(bx + bw + 3, by0 + 4), 0.7, kWhite);
        std::snprintf(text, sizeof text, "%.0f", std::round(z_bot_) + 0.0);   // + 0.0: no "-0"
        put_label(img, text, cv::Point(bx + bw + 3, by1 + 4), 0.7, kWhite);
        // The substrate level, when the scale reaches below it (trenches).
        const int y0 = by1 - cvRound((0 - z_bot_) / (z_top_ - z_bot_) * (by1 - by0));
        if (z_bot_ < 0 && y0 - by0 > 10 && by1 - y0 > 10) {
            cv::line(img, cv::Point(bx - 3, y0), cv::Point(bx - 1, y0), kWhite);
            put_label(img, "0", cv::Point(bx + bw + 3, y0 + 4), 0.7, kWhite);
        }
        put_label(img, "nm", cv::Point(bx - 2, by0 - 6), 0.7, kWhite);
    }
    // Scale bar: the largest round length up to a quarter of the field.
    const double nice[] = {10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000};
    double len = nice[0];
    for (double v : nice)
        if (v <= f_.size_nm / 4) len = v;
    const int lpx = cvRound(len / f_.pitch());
    cv::line(img, cv::Point(8, N - 10), cv::Point(8 + lpx, N - 10), cv::Scalar(0, 0, 0), 4);
    cv::line(img, cv::Point(8, N - 10), cv::Point(8 + lpx, N - 10), kWhite, 2);
    if (len >= 1000) std::snprintf(text, sizeof text, "%g um", len / 1000);
    else std::snprintf(text, sizeof text, "%g nm", len);
    put_label(img, text, cv::Point(8, N - 15), 0.7, kWhite);
    if (o.flags & fw_state_t::FLAG_INTERLOCK) draw_interlock(img);
    return img;
}

bool write_gsf(const std::string &path, const cv::Mat &h_nm, const Field &f, const std::string &title, std::string *err)
{
    return write_gsf(path, h_nm, f, cv::Rect(0, 0, h_nm.cols, h_nm.rows), title, err);
}

bool write_gsf(const std::string &path, const cv::Mat &h_nm, const Field &f, const cv::Rect &region, const std::string &title,
               std::string *err, const GsfMeta &meta)
{
    // The format is common/gsf.hpp's: here only the grid, its place in the
    // field (row 0 at the top) and the values' unit.
    GsfGrid g;
    g.xres = h_nm.cols;
    g.yres = h_nm.rows;
    g.xreal_m = region.width * f.pitch() * 1e-9;
    g.yreal_m = region.height * f.pitch() * 1e-9;
    g.xoff_m = (f.x0_nm + region.x * f.pitch()) * 1e-9;
    g.yoff_m = (f.y0_nm + (f.px - region.y - region.height) * f.pitch()) * 1e-9;
    g.z_units = meta.z_units;
    g.title = title;
    g.keys = meta.keys;
    g.values.reserve(static_cast<std::size_t>(h_nm.rows) * static_cast<std::size_t>(h_nm.cols));
    for (int r = 0; r < h_nm.rows; ++r)
        for (int c = 0; c < h_nm.cols; ++c) g.values.push_back(static_cast<float>(h_nm.at<float>(r, c) * meta.scale));
    return write_gsf_grid(path, g, err);
}

cv::Mat contact_sheet(const std::vector<cv::Mat> &frames, int cols)
{
    if (frames.empty()) return cv::Mat();
    cols = std::max(1, std::min<int>(cols, static_cast<int>(frames.size())));
    const int rows = (static_cast<int>(frames.size()) + cols - 1) / cols;
    const int w = frames[0].cols, h = frames[0].rows, gap = 4;
    cv::Mat sheet(rows * h + (rows + 1) * gap, cols * w + (cols + 1) * gap, CV_8UC3, cv::Scalar(40, 40, 40));
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const int r = static_cast<int>(i) / cols, c = static_cast<int>(i) % cols;
        frames[i].copyTo(sheet(cv::Rect(gap + c * (w + gap), gap + r * (h + gap), w, h)));
    }
    return sheet;
}

}  // namespace afm
