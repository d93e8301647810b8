#include "frame_overlay.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "afm/fw_state_t.hpp"

extern "C" {
#include "fw_board.h"
#include "fw_force.h"
}
#include "fw_units.h"

namespace afm {

namespace {

const cv::Scalar kWhite(255, 255, 255), kCyan(255, 255, 0), kTip(255, 200, 0), kYellow(0, 255, 255), kRed(0, 0, 255),
    kMarker(90, 255, 90), kFz(255, 110, 255), kFaint(235, 235, 235);
constexpr double kLateralNnAcross = 12.8;   // the lateral arrow: this many nN span the frame's side
constexpr double kFzNnAcross = 128.0;       // the F_z bar: this many nN span the frame's side
constexpr double kLeverAlpha = 0.35, kConeAlpha = 0.18;
constexpr double kBandDim = 0.35;           // the axes' bands: the image under them at this brightness

// The frame's texts and the boxes they and the marks hold: a text goes
// only where its ink, kTextGapPx round, meets nothing held.
struct Canvas {
    cv::Mat img;
    FrameText text;
    int k;        // frame pixels a display pixel
    Field f;
    int edge;     // the interlock's border and a pixel: texts keep inside it
    std::vector<cv::Rect> taken;
    FrameLayout out;

    int N() const { return img.cols; }
    // A point of frame A in the frame's pixels.
    cv::Point2d at(double x_nm, double y_nm) const
    {
        const cv::Point2d q = f.to_px(x_nm, y_nm);
        return {(q.x + 0.5) * k - 0.5, (q.y + 0.5) * k - 0.5};
    }
    cv::Rect ink(const std::string &s, cv::Point org) const { return ink_box(s, text.font_px, org); }
    bool free(const cv::Rect &ink) const
    {
        const cv::Rect inside(edge, edge, img.cols - 2 * edge, img.rows - 2 * edge);
        if ((ink & inside) != ink) return false;
        const cv::Rect r(ink.x - kTextGapPx, ink.y - kTextGapPx, ink.width + 2 * kTextGapPx, ink.height + 2 * kTextGapPx);
        return std::none_of(taken.begin(), taken.end(), [&](const cv::Rect &t) { return (t & r).area() > 0; });
    }
    void label(const std::string &s, cv::Point org, const cv::Scalar &colour, const char *role)
    {
        draw_label(img, s, org, text.font_px, colour);
        const cv::Rect r = ink(s, org);
        taken.push_back(r);
        out.texts.push_back({s, role, r, text.font_px});
    }
    bool try_label(const std::string &s, cv::Point org, const cv::Scalar &colour, const char *role)
    {
        if (!free(ink(s, org))) return false;
        label(s, org, colour, role);
        return true;
    }
    // The origin that puts s's ink's centre at p.
    cv::Point centred(const std::string &s, cv::Point p) const
    {
        const cv::Rect r = text_mask(s, text.font_px).ink;
        return {p.x - r.x - r.width / 2, p.y - r.y - r.height / 2};
    }
};

// Each pixel of src (BGR) a k x k square (cv::resize's nearest cost
// twice as much, most of it its threads' hand-over).
cv::Mat enlarge(const cv::Mat &src, int k)
{
    CV_Assert(src.type() == CV_8UC3 && k >= 1);
    if (k == 1) return src.clone();
    cv::Mat out(src.rows * k, src.cols * k, CV_8UC3);
    const std::size_t row_bytes = static_cast<std::size_t>(out.cols) * 3;
    for (int r = 0; r < src.rows; ++r) {
        const cv::Vec3b *s = src.ptr<cv::Vec3b>(r);
        cv::Vec3b *d = out.ptr<cv::Vec3b>(r * k);
        for (int col = 0; col < src.cols; ++col)
            for (int i = 0; i < k; ++i) *d++ = s[col];
        for (int i = 1; i < k; ++i) std::memcpy(out.ptr(r * k + i), out.ptr(r * k), row_bytes);
    }
    return out;
}

// A round step (1, 2, 2.5 or 5 times a power of ten, um) giving 3 to 6 ticks over the field.
double tick_step_um(double size_um)
{
    const double p = std::pow(10.0, std::floor(std::log10(size_um / 4)));
    for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
        if (size_um / (m * p) <= 6) return m * p;
    return 10 * p;
}

// The axes: the y band's width (its axis line's column A), the x band's
// height (its axis line's row N - B), and each tick (its column or row, its label).
struct AxisTick {
    int at;
    std::string label;
};
struct Axes {
    int A = 0, B = 0, T = 0, gap = 0;
    std::vector<AxisTick> x, y;
};

Axes axes_layout(const Canvas &c)
{
    const int N = c.N();
    Axes a;
    a.T = std::max(4, N / 96);
    a.gap = std::max(3, N / 170);
    const double size_um = c.f.size_nm / 1000, step = tick_step_um(size_um);
    const double x0 = c.f.x0_nm / 1000, y0 = c.f.y0_nm / 1000;
    int widest = c.ink("\u00b5m", {0, 0}).width;
    for (double v = std::ceil(y0 / step - 1e-9) * step; v <= y0 + size_um + 1e-9; v += step) {
        a.y.push_back({cvRound(c.at(c.f.x0_nm, v * 1000).y), axis_number(v)});
        widest = std::max(widest, c.ink(a.y.back().label, {0, 0}).width);
    }
    for (double v = std::ceil(x0 / step - 1e-9) * step; v <= x0 + size_um + 1e-9; v += step)
        a.x.push_back({cvRound(c.at(v * 1000, c.f.y0_nm).x), axis_number(v)});
    a.A = c.edge + widest + a.gap + a.T;
    const int below = std::max(0, c.ink("\u00b5m", {0, 0}).br().y);   // µ's descender
    a.B = a.T + a.gap + c.text.cap_px + below + c.edge;
    return a;
}

// The axes on their bands (the image under them dimmed), drawn over
// whatever lies there; their labels keep off each other and the ticks.
void draw_axes(Canvas &c, const Axes &a)
{
    const int N = c.N(), row = N - a.B, base = row + a.T + a.gap + c.text.cap_px;
    for (const cv::Rect &band : {cv::Rect(0, 0, a.A, row), cv::Rect(0, row, N, a.B)}) {
        cv::Mat roi = c.img(band);
        roi.convertTo(roi, -1, kBandDim, 0);
    }
    Canvas axes{c.img, c.text, c.k, c.f, c.edge, {}, {}};
    auto mark = [&](cv::Point p, cv::Point q) {
        cv::line(c.img, p, q, kWhite, 1);
        const cv::Rect r(std::min(p.x, q.x), std::min(p.y, q.y), std::abs(q.x - p.x) + 1, std::abs(q.y - p.y) + 1);
        axes.taken.push_back(r);
        c.out.axes.push_back(r);
    };
    mark({a.A, 0}, {a.A, row});
    mark({a.A, row}, {N - 1, row});
    for (const AxisTick &t : a.x)
        if (t.at > a.A && t.at < N) mark({t.at, row + 1}, {t.at, row + a.T});
    for (const AxisTick &t : a.y)
        if (t.at >= 0 && t.at < row) mark({a.A - a.T, t.at}, {a.A - 1, t.at});
    const cv::Rect unit = axes.ink("\u00b5m", {0, 0});
    axes.try_label("\u00b5m", {(a.A - unit.width) / 2 - unit.x, base}, kWhite, "axis unit");
    for (const AxisTick &t : a.x) {
        if (t.at <= a.A || t.at >= N) continue;
        const cv::Rect r = axes.ink(t.label, {0, 0});   // centred under its tick, or not at all
        axes.try_label(t.label, {t.at - r.x - r.width / 2, base}, kWhite, "x tick");
    }
    for (const AxisTick &t : a.y) {
        if (t.at < 0 || t.at >= row) continue;
        const cv::Rect r = axes.ink(t.label, {0, 0});   // centred on its tick's row, or not at all
        const int y = t.at - r.y - r.height / 2;
        if (y + r.br().y <= row - a.gap) axes.try_label(t.label, {a.A - a.T - a.gap - r.br().x, y}, kWhite, "y tick");
    }
    c.out.texts.insert(c.out.texts.end(), axes.out.texts.begin(), axes.out.texts.end());
}

// A label beside a box (an object's mark), in the first place round it
// that nothing else holds; none where every place is held (a dense pattern
// keeps its rings, and names what it can).
void label_beside(Canvas &c, const std::string &s, const cv::Rect &mark, const cv::Scalar &colour)
{
    const cv::Rect r = c.ink(s, {0, 0});
    const int g = kTextGapPx + 1, cy = mark.y + mark.height / 2, cx = mark.x + mark.width / 2;
    const cv::Point tries[] = {{mark.br().x + g - r.x, cy - r.y - r.height / 2},        {mark.x - g - r.br().x, cy - r.y - r.height / 2},
                               {cx - r.x - r.width / 2, mark.y - g - r.br().y},        {cx - r.x - r.width / 2, mark.br().y + g - r.y},
                               {mark.br().x + g - r.x, mark.y - g - r.br().y},          {mark.br().x + g - r.x, mark.br().y + g - r.y},
                               {mark.x - g - r.br().x, mark.y - g - r.br().y},          {mark.x - g - r.br().x, mark.br().y + g - r.y}};
    for (const cv::Point &org : tries)
        if (c.try_label(s, org, colour, "id")) return;
}

// Each particle ringed (at least kMinMarkerPx across); the rings' boxes,
// which the labels keep off.
std::vector<cv::Rect> draw_rings(Canvas &c, const DisplayModel &m)
{
    std::vector<cv::Rect> rings;
    const int lw = std::max(1, c.N() / 384);
    for (const auto &p : m.particles) {
        const cv::Point2d q = c.at(p.x_nm, p.y_nm);
        const int r = cvRound(std::max((p.radius_nm / c.f.pitch() + 1.5) * c.k, kMinMarkerPx / 2.0));
        const cv::Point ctr(cvRound(q.x), cvRound(q.y));
        cv::circle(c.img, ctr, r, kMarker, lw, cv::LINE_AA);
        rings.emplace_back(ctr.x - r - lw, ctr.y - r - lw, 2 * (r + lw) + 1, 2 * (r + lw) + 1);
    }
    return rings;
}

// The objects' ids where there is room: particles (p<id>) beside their
// rings, wires (w<id>) at their middle, trenches (t<id>) at their start.
void draw_ids(Canvas &c, const DisplayModel &m, const std::vector<cv::Rect> &rings)
{
    for (std::size_t i = 0; i < m.particles.size(); ++i) label_beside(c, "p" + std::to_string(m.particles[i].id), rings[i], kMarker);
    for (const auto &w : m.wires) {
        if (w.nodes_nm.empty()) continue;
        const cv::Point2d &a = w.nodes_nm.front(), &b = w.nodes_nm.back();
        const cv::Point2d q = c.at((a.x + b.x) / 2, (a.y + b.y) / 2);
        const int off = cvRound(w.diameter_nm / c.f.pitch() * c.k / 2) + 2;
        label_beside(c, "w" + std::to_string(w.id), cv::Rect(cvRound(q.x) - off, cvRound(q.y) - off, 2 * off, 2 * off), kMarker);
    }
    for (const auto &t : m.trenches) {
        if (t.points.empty()) continue;
        const cv::Point2d q = c.at(t.points.front().x_nm, t.points.front().y_nm);
        const int off = 3 * c.k;
        label_beside(c, "t" + std::to_string(t.id), cv::Rect(cvRound(q.x) - off, cvRound(q.y) - off, 2 * off, 2 * off), kMarker);
    }
}

// The lever from the tip back towards its base, faint; while the tip
// pushes, the cones about its axis where F_x is unobservable, fainter.
// Returns the line's far end (the base's side).
cv::Point draw_lever(Canvas &c, cv::Point tip, const Overlay &o, const LeverView &lever)
{
    const int N = c.N();
    const double ux = lever.axis[0], uy = -lever.axis[1];   // image rows run down
    const cv::Point base_full = tip - cv::Point(cvRound(ux * N / 5.0), cvRound(uy * N / 5.0));
    const int lw = std::max(3, N / 64);
    const bool cones = o.flags & fw_state_t::FLAG_CONTACT;
    std::vector<std::vector<cv::Point>> wedges;
    if (cones) {
        const double a = lever.blind_half_angle_deg * M_PI / 180, R = N / 4.0;
        for (double sgn : {1.0, -1.0}) {
            wedges.push_back({tip});
            for (int i = -8; i <= 8; ++i) {
                const double th = std::atan2(sgn * uy, sgn * ux) + a * i / 8.0;
                wedges.back().emplace_back(tip + cv::Point(cvRound(R * std::cos(th)), cvRound(R * std::sin(th))));
            }
        }
    }
    // blend only where something is drawn: the box of the line and the cones
    cv::Rect box = cv::Rect(tip, base_full) | cv::Rect(base_full, tip);
    for (const auto &w : wedges) box |= cv::boundingRect(w);
    const cv::Rect roi = cv::Rect(box.x - lw, box.y - lw, box.width + 2 * lw + 1, box.height + 2 * lw + 1) & cv::Rect(0, 0, N, c.img.rows);
    if (roi.empty()) return base_full;
    cv::Mat img = c.img(roi);
    const cv::Point t = tip - roi.tl();
    cv::Mat layer = img.clone();
    if (cones) {
        for (auto &w : wedges)
            for (auto &p : w) p -= roi.tl();
        cv::fillPoly(layer, wedges, kFaint, cv::LINE_AA);
        cv::addWeighted(img, 1 - kConeAlpha, layer, kConeAlpha, 0, img);
        img.copyTo(layer);
    }
    cv::line(layer, t, base_full - roi.tl(), kFaint, lw, cv::LINE_AA);
    cv::addWeighted(img, 1 - kLeverAlpha, layer, kLeverAlpha, 0, img);
    return base_full;
}

// "lever" beside the lever's line, nearest its far end where there is room.
void label_lever(Canvas &c, cv::Point tip, cv::Point base)
{
    const cv::Point2d d(base.x - tip.x, base.y - tip.y);
    const double len = std::max(1.0, std::hypot(d.x, d.y));
    const cv::Point2d n(-d.y / len, d.x / len);   // across the line
    const cv::Rect r = c.ink("lever", {0, 0});
    const double side = std::max(r.width, r.height) / 2.0 + c.N() / 64.0 + kTextGapPx;
    for (double frac : {1.0, 0.8, 0.6, 0.4})
        for (double s : {1.0, -1.0}) {
            const cv::Point p(cvRound(tip.x + d.x * frac + s * n.x * side), cvRound(tip.y + d.y * frac + s * n.y * side));
            if (c.try_label("lever", c.centred("lever", p), kFaint, "lever")) return;
        }
}

// The tip, the lateral force as an arrow from it and F_z as a bar beside it.
void draw_force_glyph(Canvas &c, cv::Point tip, const Overlay &o)
{
    const int N = c.N(), lw = std::max(1, N / 256);
    const double lat = N / kLateralNnAcross, fz = N / kFzNnAcross;
    cv::circle(c.img, tip, std::max(3, N / 128), kTip, lw, cv::LINE_AA);
    const double lim = N / 2.0;
    const cv::Point fv(cvRound(std::clamp(o.force_nN[0] * lat, -lim, lim)), cvRound(std::clamp(-o.force_nN[1] * lat, -lim, lim)));
    if (fv.x || fv.y) cv::arrowedLine(c.img, tip, tip + fv, kCyan, lw, cv::LINE_AA, 0, 0.2);
    const int h = cvRound(std::clamp(o.force_nN[2] * fz, -N / 3.0, N / 3.0));
    if (h != 0) {
        const int w = std::max(3, N / 128);
        const cv::Rect bar(tip.x + 2 * w, std::min(tip.y, tip.y - h), w, std::abs(h));
        cv::rectangle(c.img, bar + cv::Size(2, 2) - cv::Point(1, 1), cv::Scalar(0, 0, 0), 1);
        cv::rectangle(c.img, bar, kFz, cv::FILLED);
    }
}

// A round reference: the largest of 1, 2, 5 x 10^n not over `most`.
double round_below(double most)
{
    const double p = std::pow(10.0, std::floor(std::log10(most)));
    for (double m : {5.0, 2.0, 1.0})
        if (m * p <= most) return m * p;
    return p;
}

// The hand's gauge: a ring of hand_scale_N and the hand's force as an arrow in it.
void draw_gauge(Canvas &c, const Overlay &o, cv::Point ctr, int rad)
{
    const int lw = std::max(1, c.N() / 256);
    cv::circle(c.img, ctr, rad, kYellow, lw, cv::LINE_AA);
    const double k = rad / o.hand_scale_N;
    const cv::Point hv(cvRound(std::clamp(o.hand_N[0] * k, -1.0 * rad, 1.0 * rad)), cvRound(std::clamp(-o.hand_N[1] * k, -1.0 * rad, 1.0 * rad)));
    if (hv.x || hv.y) cv::arrowedLine(c.img, ctr, ctr + hv, kYellow, lw, cv::LINE_AA, 0, 0.25);
    c.taken.emplace_back(ctr.x - rad - lw, ctr.y - rad - lw, 2 * (rad + lw) + 1, 2 * (rad + lw) + 1);
}

// The legend, bottom left above the x axis, on a dimmed panel: each
// glyph at its scale, the values, and the hand's gauge in words, its ring
// right of the lines (or above them where the colour bar leaves no room).
void draw_legend(Canvas &c, const Overlay &o, const Axes &a, int right)
{
    const int N = c.N(), L = c.text.line_px, x = a.A + 6, lw = std::max(1, N / 256), cap = c.text.cap_px;
    const double lat = N / kLateralNnAcross, fz = N / kFzNnAcross;
    const double lat_ref = round_below(N / 8.0 / lat), fz_ref = round_below(cap * 1.5 / fz);
    const int aw = cvRound(lat_ref * lat), bh = cvRound(fz_ref * fz), bw = std::max(3, N / 128);
    std::vector<std::pair<std::string, cv::Point>> lines = {
        {label_number("%g nN", lat_ref) + label_number("   lateral F %.2f nN", std::hypot(o.force_nN[0], o.force_nN[1])), {x + aw + 6, 0}},
        {label_number("%g nN", fz_ref) + label_number("   F_z %.2f nN (bar)", o.force_nN[2]), {x + bw + 8, 0}}};
    if (o.hand_scale_N > 0)
        lines.push_back({label_number("hand feels %.0f mN", 1e3 * std::hypot(o.hand_N[0], o.hand_N[1])) + label_number(", ring %.0f mN", 1e3 * o.hand_scale_N), {x, 0}});
    const int last = N - a.B - a.gap - c.text.font_px / 4 - 2;   // the last line's baseline: its descenders above the band
    cv::Rect panel(x, last - static_cast<int>(lines.size() - 1) * L - std::max(cap, bh), 1, 1);
    for (std::size_t i = 0; i < lines.size(); ++i) {
        lines[i].second.y = last - static_cast<int>(lines.size() - 1 - i) * L;
        panel |= c.ink(lines[i].first, lines[i].second);
    }
    panel = cv::Rect(panel.x - 4, panel.y - 3, panel.width + 8, panel.height + 6) & cv::Rect(a.A + 1, 0, N - a.A - 1, N - a.B);
    cv::Mat under = c.img(panel);
    under.convertTo(under, -1, 0.5, 0);
    c.taken.push_back(panel);
    const cv::Point arrow(x, lines[0].second.y - cap / 2);
    cv::arrowedLine(c.img, arrow, arrow + cv::Point(aw, 0), kCyan, lw, cv::LINE_AA, 0, 0.25);
    cv::rectangle(c.img, cv::Rect(x + 2, lines[1].second.y - bh, bw, bh), kFz, cv::FILLED);
    const cv::Scalar colours[] = {kCyan, kFz, kYellow};
    for (std::size_t i = 0; i < lines.size(); ++i) {
        draw_label(c.img, lines[i].first, lines[i].second, c.text.font_px, colours[i]);
        c.out.texts.push_back({lines[i].first, "legend", c.ink(lines[i].first, lines[i].second), c.text.font_px});
    }
    if (o.hand_scale_N <= 0) return;
    const int rad = std::max(8, N / 20);
    const cv::Point beside(panel.br().x + 2 * kTextGapPx + rad + lw, last - rad);
    draw_gauge(c, o, beside.x + rad + lw + kTextGapPx < right ? beside : cv::Point(x + rad + lw, panel.y - 2 * kTextGapPx - rad - lw), rad);
}

// Time and flags, top left (right of the y axis).
void draw_status(Canvas &c, const Overlay &o, const Axes &a)
{
    const int x = a.A + 6, y = c.edge + c.text.cap_px + 2;
    c.label(label_number("t %.2f s", o.t_s), cv::Point(x, y), kWhite, "status");
    const std::string flags = flag_words(o.flags);   // the display's one list
    if (!flags.empty()) c.label(flags.substr(0, flags.find_last_not_of(' ') + 1), cv::Point(x, y + c.text.line_px), kYellow, "status");
}

// The height colour bar, nm, at the right edge under the status lines and
// the interlock's banner, above the legend's lowest line; its values left
// of it. Returns its labels' leftmost column (N if none drawn).
int draw_colour_bar(Canvas &c, const Display &d, const Axes &a)
{
    const int N = c.N(), bw = std::max(8, N / 48), L = c.text.line_px;
    const int top = 4 * L + c.edge, bottom = N - a.B - L;
    if (bottom - top < 3 * L) return N;
    const int bx = N - c.edge - bw - 1;
    cv::Mat h(bottom - top, 1, CV_32F);
    for (int i = 0; i < h.rows; ++i) h.at<float>(i) = static_cast<float>(d.z_top() - (d.z_top() - d.z_bottom()) * i / (h.rows - 1));
    cv::Mat col = d.colourise(h), bar;
    cv::repeat(col, 1, bw, bar);
    bar.copyTo(c.img(cv::Rect(bx, top, bw, h.rows)));
    cv::rectangle(c.img, cv::Rect(bx - 1, top - 1, bw + 2, h.rows + 2), kWhite);
    c.taken.emplace_back(bx - 1, top - 1, bw + 2, h.rows + 2);
    int left = bx - 1;
    auto value = [&](double z, int row) {
        const std::string s = axis_number(std::round(z));
        const cv::Rect r = c.ink(s, {0, 0});
        const cv::Point org(bx - 1 - kTextGapPx - 2 - r.br().x, row - r.y - r.height / 2);
        if (c.try_label(s, org, kWhite, "bar")) left = std::min(left, org.x + r.x);
    };
    value(d.z_top(), top);
    value(d.z_bottom(), bottom - 1);
    if (d.z_bottom() < 0 && d.z_top() > 0) value(0, top + cvRound((h.rows - 1) * d.z_top() / (d.z_top() - d.z_bottom())));
    const cv::Rect u = c.ink("nm", {0, 0});
    c.try_label("nm", {N - c.edge - 1 - u.br().x, top - c.text.cap_px / 2 - 2 * kTextGapPx - 2 - u.br().y}, kWhite, "bar");   // above the top value
    return left;
}

// The interlock's banner: a red band across the frame under the status
// lines, "INTERLOCK: TIP RETRACTED" (shorter on a narrow frame).
void draw_interlock_banner(Canvas &c, const Axes &a)
{
    const int N = c.N(), L = c.text.line_px;
    const cv::Rect band(a.A + 1, 2 * L + c.edge, N - a.A - 1 - c.edge, L + 2);
    cv::rectangle(c.img, band, kRed, cv::FILLED);
    c.taken.push_back(band);
    for (const char *text : {"INTERLOCK: TIP RETRACTED", "INTERLOCK: RETRACTED", "INTERLOCK"}) {
        const cv::Rect r = c.ink(text, {0, 0});
        if (r.width <= band.width - 12 || std::string(text) == "INTERLOCK") {
            const cv::Point org(band.x + 6 - r.x, band.y + band.height / 2 - r.y - r.height / 2);
            draw_text(c.img, text, org, c.text.font_px, kWhite);
            c.out.texts.push_back({text, "banner", c.ink(text, org), c.text.font_px});
            break;
        }
    }
}

// The interlock's border, round the whole frame, drawn last.
void draw_interlock_border(Canvas &c)
{
    const int N = c.N(), M = c.img.rows, t = c.edge - 1;
    for (const cv::Rect &edge : {cv::Rect(0, 0, N, t), cv::Rect(0, M - t, N, t), cv::Rect(0, 0, t, M), cv::Rect(N - t, 0, t, M)})
        cv::rectangle(c.img, edge, kRed, cv::FILLED);
}

}  // namespace

LeverView lever_view(double scan_angle_deg)
{
    LeverView v;
    q30_t axis[2];
    fw_board_lever_axis_q30(fwu_mdeg_from_deg(scan_angle_deg), axis);
    v.axis[0] = fwu_from_q30(axis[0]);
    v.axis[1] = fwu_from_q30(axis[1]);
    // S_HI (fw_force.h, 2.30): |sin| of the angle below which F_x is unobservable.
    const double s_hi = static_cast<double>(FW_FORCE_SIN_HI_Q30) / static_cast<double>(static_cast<int64_t>(1) << FW_Q30_FRAC);
    v.blind_half_angle_deg = std::asin(s_hi) * 180 / M_PI;
    return v;
}

int frame_px(int display_px)
{
    const int px = std::max(1, display_px);
    return px * ((kMinFramePx + px - 1) / px);
}

FrameText frame_text(int frame_px)
{
    FrameText t;
    t.font_px = std::max(14, cvRound(14.0 * frame_px / kMinFramePx));
    t.cap_px = cap_height_px(t.font_px);
    t.line_px = t.font_px + std::max(4, t.font_px / 3);
    return t;
}

cv::Mat compose_frame(const Display &d, const DisplayModel &model, const Overlay &o, const LeverView &lever, FrameLayout *layout)
{
    const Field &f = d.field();
    const int N = frame_px(f.px), k = N / f.px;
    // the display's own colourised heights (kept as they change), each
    // pixel a k x k square of the frame
    const cv::Mat img = enlarge(d.colour().empty() ? d.colourise(d.height()) : d.colour(), k);
    Canvas c{img, frame_text(N), k, f, std::max(2, N / 128) + 1, {}, {}};
    for (const auto &p : d.trail_points())
        cv::circle(c.img, cv::Point(cvRound((p.x + 0.5) * k - 0.5), cvRound((p.y + 0.5) * k - 0.5)), std::max(1, k / 2), cv::Scalar(120, 120, 120), cv::FILLED);
    const Axes axes = axes_layout(c);
    c.taken = {cv::Rect(0, 0, axes.A + 1, N), cv::Rect(0, N - axes.B, N, axes.B)};   // the axes' bands: their own texts only
    c.out.bands = c.taken;
    const cv::Point2d tp = c.at(o.tip_nm[0], o.tip_nm[1]);
    const cv::Point tip(cvRound(tp.x), cvRound(tp.y));
    // the marks first; then the texts, each where no other is
    const cv::Point base = draw_lever(c, tip, o, lever);
    const std::vector<cv::Rect> rings = draw_rings(c, model);
    draw_force_glyph(c, tip, o);
    const bool interlock = o.flags & fw_state_t::FLAG_INTERLOCK;
    if (interlock) draw_interlock_banner(c, axes);
    draw_status(c, o, axes);
    const int bar_left = draw_colour_bar(c, d, axes);
    c.taken.insert(c.taken.end(), rings.begin(), rings.end());
    draw_legend(c, o, axes, bar_left);
    label_lever(c, tip, base);
    draw_ids(c, model, rings);
    draw_axes(c, axes);
    if (interlock) draw_interlock_border(c);
    if (layout) *layout = std::move(c.out);
    return c.img;
}

}  // namespace afm
