#include "frame_overlay.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
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

// A label's coverage masks: the text, anti-aliased, and its outline (the
// text dilated by a pixel), in a box `pad` pixels round the text; kept per
// text and scale (most labels are the same every frame: axes, ids, units).
struct LabelMasks {
    cv::Mat text_a, outline_a;
    cv::Point offset;   // the box's corner from the text's origin
};

const LabelMasks &label_masks(const std::string &text, double scale)
{
    static thread_local std::map<std::pair<std::string, double>, LabelMasks> cache;
    constexpr std::size_t kMaxCached = 1024;
    auto it = cache.find({text, scale});
    if (it != cache.end()) return it->second;
    if (cache.size() >= kMaxCached) cache.clear();
    int baseline = 0;
    const cv::Size sz = cv::getTextSize(text, cv::FONT_HERSHEY_PLAIN, scale, 1, &baseline);
    const int pad = 3, above = sz.height / 2 + pad;
    LabelMasks m;
    m.offset = cv::Point(-pad, -sz.height - above);
    m.text_a = cv::Mat::zeros(sz.height + above + baseline + pad, sz.width + 2 * pad, CV_8U);
    cv::putText(m.text_a, text, -m.offset, cv::FONT_HERSHEY_PLAIN, scale, cv::Scalar(255), 1, cv::LINE_AA);
    cv::dilate(m.text_a, m.outline_a, cv::Mat());
    return cache.emplace(std::make_pair(text, scale), std::move(m)).first->second;
}

// Text legible on any colour of the map: the dark outline blended under it.
void put_label(cv::Mat &img, const std::string &text, cv::Point org, double scale, const cv::Scalar &colour)
{
    const LabelMasks &m = label_masks(text, scale);
    const cv::Rect box(org + m.offset, m.text_a.size());
    const cv::Rect on = box & cv::Rect(0, 0, img.cols, img.rows);
    if (on.empty()) return;
    // label_blend for whole colours (all the overlay's), else the same in doubles
    const bool whole = colour[0] == std::floor(colour[0]) && colour[1] == std::floor(colour[1]) && colour[2] == std::floor(colour[2]) &&
                       colour[0] >= 0 && colour[1] >= 0 && colour[2] >= 0 && colour[0] <= 255 && colour[1] <= 255 && colour[2] <= 255;
    const int c[3] = {static_cast<int>(colour[0]), static_cast<int>(colour[1]), static_cast<int>(colour[2])};
    for (int y = on.y; y < on.br().y; ++y) {
        cv::Vec3b *px = img.ptr<cv::Vec3b>(y) + on.x;
        const uchar *t = m.text_a.ptr<uchar>(y - box.y) + (on.x - box.x);
        const uchar *o = m.outline_a.ptr<uchar>(y - box.y) + (on.x - box.x);
        for (int x = 0; x < on.width; ++x) {
            if (!o[x]) continue;
            for (int k = 0; k < 3; ++k) {
                if (whole) {
                    px[x][k] = label_blend(px[x][k], o[x], t[x], c[k]);
                } else {
                    const double under = px[x][k] * (255 - o[x]) / 255.0;
                    px[x][k] = cv::saturate_cast<uchar>(under + (colour[k] - under) * t[x] / 255.0);
                }
            }
        }
    }
}

cv::Size text_size(const std::string &text, double scale)
{
    int baseline = 0;
    return cv::getTextSize(text, cv::FONT_HERSHEY_PLAIN, scale, 1, &baseline);
}

// The frame's labels, and the boxes they hold (axis labels give way to them).
struct Canvas {
    cv::Mat img;
    FrameText text;
    std::vector<cv::Rect> taken;

    cv::Rect box_of(const std::string &s, cv::Point org) const
    {
        const cv::Size sz = text_size(s, text.scale);
        return cv::Rect(org.x - 2, org.y - sz.height - 2, sz.width + 4, sz.height + 5);
    }
    void label(const std::string &s, cv::Point org, const cv::Scalar &colour)
    {
        put_label(img, s, org, text.scale, colour);
        taken.push_back(box_of(s, org));
    }
    bool free(const cv::Rect &r) const
    {
        if ((r & cv::Rect(0, 0, img.cols, img.rows)) != r) return false;
        return std::none_of(taken.begin(), taken.end(), [&](const cv::Rect &t) { return (t & r).area() > 0; });
    }
};

std::string fmt(const char *f, double v)
{
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

// A round step (1, 2, 2.5 or 5 times a power of ten, um) giving 3 to 6 ticks over the field.
double tick_step_um(double size_um)
{
    const double p = std::pow(10.0, std::floor(std::log10(size_um / 4)));
    for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
        if (size_um / (m * p) <= 6) return m * p;
    return 10 * p;
}

// Ticks and labels in um along the bottom (x) and left (y) edges.
void draw_axes(Canvas &c, const Field &f)
{
    const int N = f.px;
    const double size_um = f.size_nm / 1000, step = tick_step_um(size_um);
    const double x0 = f.x0_nm / 1000, y0 = f.y0_nm / 1000;
    const int tick = std::max(4, N / 48);
    c.label("x um", cv::Point(N - text_size("x um", c.text.scale).width - 4 - N / 5, N - 4), kWhite);
    c.label("y um", cv::Point(4, 3 * c.text.line_px + 4), kWhite);
    for (double v = std::ceil(x0 / step - 1e-9) * step; v <= x0 + size_um + 1e-9; v += step) {
        const int col = cvRound(f.to_px(v * 1000, f.y0_nm).x);
        cv::line(c.img, cv::Point(col, N - 1), cv::Point(col, N - tick), kWhite, 1);
        const std::string s = fmt("%g", std::fabs(v) < 1e-9 ? 0.0 : v);
        const cv::Point org(col - text_size(s, c.text.scale).width / 2, N - tick - 3);
        if (c.free(c.box_of(s, org))) c.label(s, org, kWhite);
    }
    for (double v = std::ceil(y0 / step - 1e-9) * step; v <= y0 + size_um + 1e-9; v += step) {
        const int row = cvRound(f.to_px(f.x0_nm, v * 1000).y);
        cv::line(c.img, cv::Point(0, row), cv::Point(tick - 1, row), kWhite, 1);
        const std::string s = fmt("%g", std::fabs(v) < 1e-9 ? 0.0 : v);
        const cv::Point org(tick + 3, row + c.text.cap_px / 2);
        if (c.free(c.box_of(s, org))) c.label(s, org, kWhite);
    }
}

// A label beside a box (an object's mark), in the first place round it
// that nothing else holds; none where every place is held (a dense pattern
// keeps its rings, and names what it can).
void label_beside(Canvas &c, const std::string &s, const cv::Rect &mark, const cv::Scalar &colour)
{
    const cv::Size sz = text_size(s, c.text.scale);
    const cv::Point tries[] = {{mark.br().x + 2, mark.y + sz.height / 2}, {mark.x - sz.width - 3, mark.y + sz.height / 2},
                               {mark.x + mark.width / 2 - sz.width / 2, mark.y - 4},
                               {mark.x + mark.width / 2 - sz.width / 2, mark.br().y + sz.height + 3}};
    for (const cv::Point &org : tries)
        if (c.free(c.box_of(s, org))) {
            c.label(s, org, colour);
            return;
        }
}

// Each particle ringed (at least kMinMarkerPx across); the rings' boxes,
// which the labels keep off.
std::vector<cv::Rect> draw_rings(Canvas &c, const Field &f, const DisplayModel &m)
{
    std::vector<cv::Rect> rings;
    for (const auto &p : m.particles) {
        const cv::Point2d q = f.to_px(p.x_nm, p.y_nm);
        const int r = cvRound(std::max(p.radius_nm / f.pitch() + 1.5, kMinMarkerPx / 2.0));
        const cv::Point ctr(cvRound(q.x), cvRound(q.y));
        cv::circle(c.img, ctr, r, kMarker, 1, cv::LINE_AA);
        rings.emplace_back(ctr.x - r, ctr.y - r, 2 * r + 1, 2 * r + 1);
    }
    return rings;
}

// The objects' ids where there is room: particles (p<id>) beside their
// rings, wires (w<id>) at their middle, trenches (t<id>) at their start.
void draw_ids(Canvas &c, const Field &f, const DisplayModel &m, const std::vector<cv::Rect> &rings)
{
    c.taken.insert(c.taken.end(), rings.begin(), rings.end());
    for (std::size_t i = 0; i < m.particles.size(); ++i) label_beside(c, "p" + std::to_string(m.particles[i].id), rings[i], kMarker);
    for (const auto &w : m.wires) {
        if (w.nodes_nm.empty()) continue;
        const cv::Point2d &a = w.nodes_nm.front(), &b = w.nodes_nm.back();
        const cv::Point2d q = f.to_px((a.x + b.x) / 2, (a.y + b.y) / 2);
        const int off = cvRound(w.diameter_nm / f.pitch() / 2) + 2;
        label_beside(c, "w" + std::to_string(w.id), cv::Rect(cvRound(q.x) - off, cvRound(q.y) - off, 2 * off, 2 * off), kMarker);
    }
    for (const auto &t : m.trenches) {
        if (t.points.empty()) continue;
        const cv::Point2d q = f.to_px(t.points.front().x_nm, t.points.front().y_nm);
        label_beside(c, "t" + std::to_string(t.id), cv::Rect(cvRound(q.x) - 3, cvRound(q.y) - 3, 6, 6), kMarker);
    }
}

// The lever from the tip back towards its base, faint; while the tip
// pushes, the cones about its axis where F_x is unobservable, fainter.
void draw_lever(Canvas &c, cv::Point tip, const Overlay &o, const LeverView &lever)
{
    const int N = c.img.cols, reach = N / 4 + 2;
    const double ux = lever.axis[0], uy = -lever.axis[1];   // image rows run down
    // everything drawn lies within `reach` of the tip: blend there only
    const cv::Rect roi = cv::Rect(tip.x - reach, tip.y - reach, 2 * reach + 1, 2 * reach + 1) & cv::Rect(0, 0, N, c.img.rows);
    if (roi.empty()) return;
    cv::Mat img = c.img(roi);
    const cv::Point t = tip - roi.tl();
    cv::Mat layer = img.clone();
    if (o.flags & fw_state_t::FLAG_CONTACT) {
        const double a = lever.blind_half_angle_deg * M_PI / 180, R = N / 4.0;
        for (double sgn : {1.0, -1.0}) {
            std::vector<cv::Point> wedge{t};
            for (int i = -8; i <= 8; ++i) {
                const double th = std::atan2(sgn * uy, sgn * ux) + a * i / 8.0;
                wedge.emplace_back(t + cv::Point(cvRound(R * std::cos(th)), cvRound(R * std::sin(th))));
            }
            cv::fillPoly(layer, std::vector<std::vector<cv::Point>>{wedge}, kFaint, cv::LINE_AA);
        }
        cv::addWeighted(img, 1 - kConeAlpha, layer, kConeAlpha, 0, img);
        img.copyTo(layer);
    }
    const cv::Point base = t - cv::Point(cvRound(ux * N / 5.0), cvRound(uy * N / 5.0));
    cv::line(layer, t, base, kFaint, std::max(3, N / 64), cv::LINE_AA);
    cv::addWeighted(img, 1 - kLeverAlpha, layer, kLeverAlpha, 0, img);
    const cv::Size sz = text_size("lever", c.text.scale);
    const cv::Point b = base + roi.tl();
    const cv::Point org(std::clamp(b.x - sz.width / 2, 2, N - sz.width - 2), std::clamp(b.y + (uy > 0 ? -6 : sz.height + 6), sz.height + 2, N - 4));
    c.label("lever", org, kFaint);
}

// The tip, the lateral force as an arrow from it and F_z as a bar beside it.
void draw_force_glyph(Canvas &c, cv::Point tip, const Overlay &o)
{
    const int N = c.img.cols;
    const double lat = N / kLateralNnAcross, fz = N / kFzNnAcross;
    cv::circle(c.img, tip, 3, kTip, 1, cv::LINE_AA);
    const double lim = N / 2.0;
    const cv::Point fv(cvRound(std::clamp(o.force_nN[0] * lat, -lim, lim)), cvRound(std::clamp(-o.force_nN[1] * lat, -lim, lim)));
    if (fv.x || fv.y) cv::arrowedLine(c.img, tip, tip + fv, kCyan, 1, cv::LINE_AA, 0, 0.2);
    const int h = cvRound(std::clamp(o.force_nN[2] * fz, -N / 3.0, N / 3.0));
    if (h != 0) {
        const cv::Rect bar(tip.x + 6, std::min(tip.y, tip.y - h), 3, std::abs(h));
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

// The legend, bottom left above the x axis: each glyph at its scale, the
// values, and the hand's gauge in words.
void draw_legend(Canvas &c, const Overlay &o)
{
    const int N = c.img.cols, L = c.text.line_px, x = 6;
    const double lat = N / kLateralNnAcross, fz = N / kFzNnAcross;
    const int lines = o.hand_scale_N > 0 ? 3 : 2;
    int y = N - std::max(4, N / 48) - c.text.cap_px - 10 - (lines - 1) * L;
    const double lat_ref = round_below(N / 8.0 / lat), fz_ref = round_below(c.text.cap_px * 1.5 / fz);
    const int aw = cvRound(lat_ref * lat);
    cv::arrowedLine(c.img, cv::Point(x, y - c.text.cap_px / 2), cv::Point(x + aw, y - c.text.cap_px / 2), kCyan, 1, cv::LINE_AA, 0, 0.25);
    c.label(fmt("%g nN", lat_ref) + fmt("  lateral F %.2f nN", std::hypot(o.force_nN[0], o.force_nN[1])), cv::Point(x + aw + 5, y), kCyan);
    y += L;
    const int bh = cvRound(fz_ref * fz);
    cv::rectangle(c.img, cv::Rect(x + 2, y - bh, 3, bh), kFz, cv::FILLED);
    c.label(fmt("%g nN", fz_ref) + fmt("  F_z %.2f nN (bar)", o.force_nN[2]), cv::Point(x + 10, y), kFz);
    if (o.hand_scale_N <= 0) return;
    y += L;
    const int rad = std::max(8, N / 16);
    const std::string words = fmt("hand feels %.0f mN", 1e3 * std::hypot(o.hand_N[0], o.hand_N[1])) + fmt(", ring %.0f mN", 1e3 * o.hand_scale_N);
    c.label(words, cv::Point(x, y), kYellow);
    // right of the words where it fits left of the colour bar, else above the legend's right end
    const int right = N - std::max(4, N / 40) - 8 - text_size("000", c.text.scale).width - 6;
    const int after = x + text_size(words, c.text.scale).width + rad + 8;
    const cv::Point ctr = after + rad <= right ? cv::Point(after, y - c.text.cap_px / 2)
                                               : cv::Point(right - rad, y - 2 * L - c.text.cap_px - rad - 4);
    cv::circle(c.img, ctr, rad, kYellow, 1, cv::LINE_AA);
    const double k = rad / o.hand_scale_N;
    const cv::Point hv(cvRound(std::clamp(o.hand_N[0] * k, -2.0 * rad, 2.0 * rad)), cvRound(std::clamp(-o.hand_N[1] * k, -2.0 * rad, 2.0 * rad)));
    if (hv.x || hv.y) cv::arrowedLine(c.img, ctr, ctr + hv, kYellow, 1, cv::LINE_AA, 0, 0.25);
}

// Time and flags, top left.
void draw_status(Canvas &c, const Overlay &o)
{
    c.label(fmt("t %.2f s", o.t_s), cv::Point(4, c.text.cap_px + 5), kWhite);
    const std::string flags = flag_words(o.flags);   // the display's one list
    if (!flags.empty()) c.label(flags, cv::Point(4, c.text.cap_px + 5 + c.text.line_px), kYellow);
}

// The height colour bar, nm, at the right edge.
void draw_colour_bar(Canvas &c, const Display &d)
{
    // from below the flags to above the legend's three lines and the x axis
    const int N = c.img.cols, bw = std::max(4, N / 40), top = 2 * c.text.line_px, bottom = N - 5 * c.text.line_px;
    if (bottom - top < 21) return;
    const int bx = N - bw - 8 - text_size("000", c.text.scale).width;
    cv::Mat h(bottom - top, 1, CV_32F);
    for (int i = 0; i < h.rows; ++i) h.at<float>(i) = static_cast<float>(d.z_top() - (d.z_top() - d.z_bottom()) * i / (h.rows - 1));
    cv::Mat col = d.colourise(h), bar;
    cv::repeat(col, 1, bw, bar);
    bar.copyTo(c.img(cv::Rect(bx, top, bw, h.rows)));
    cv::rectangle(c.img, cv::Rect(bx - 1, top - 1, bw + 2, h.rows + 2), kWhite);
    c.label(fmt("%.0f", d.z_top()), cv::Point(bx + bw + 3, top + c.text.cap_px / 2), kWhite);
    c.label(fmt("%.0f", std::round(d.z_bottom()) + 0.0), cv::Point(bx + bw + 3, bottom + c.text.cap_px / 2), kWhite);
    c.label("nm", cv::Point(bx - text_size("nm", c.text.scale).width - 5, top + c.text.cap_px / 2), kWhite);
    c.taken.push_back(cv::Rect(bx - 2, top, N - bx + 2, h.rows));
}

// The interlock's mark: a red border round the frame and a banner.
void draw_interlock(Canvas &c)
{
    const int N = c.img.cols, M = c.img.rows, t = std::max(2, N / 128);
    for (const cv::Rect &edge : {cv::Rect(0, 0, N, t), cv::Rect(0, M - t, N, t), cv::Rect(0, 0, t, M), cv::Rect(N - t, 0, t, M)})
        cv::rectangle(c.img, edge, kRed, cv::FILLED);
    const int y = 2 * c.text.line_px + 2;
    cv::rectangle(c.img, cv::Rect(t, y, N - 2 * t, c.text.line_px + 2), kRed, cv::FILLED);
    for (const char *text : {"INTERLOCK: TIP RETRACTED", "INTERLOCK: RETRACTED", "INTERLOCK"})
        if (text_size(text, c.text.scale).width <= N - 2 * t - 6 || std::string(text) == "INTERLOCK") {
            cv::putText(c.img, text, cv::Point(t + 3, y + c.text.cap_px + 3), cv::FONT_HERSHEY_PLAIN, c.text.scale, kWhite, 1, cv::LINE_AA);
            break;
        }
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

FrameText frame_text(int px)
{
    FrameText t;
    t.scale = 0.9 * std::max(1.0, px / 256.0);
    t.cap_px = text_size("H", t.scale).height;
    t.line_px = t.cap_px + std::max(5, t.cap_px / 2);
    return t;
}

cv::Mat compose_frame(const Display &d, const DisplayModel &model, const Overlay &o, const LeverView &lever)
{
    const Field &f = d.field();
    // the display's own colourised heights (kept as they change), copied:
    // colourising the whole map again cost a third of composing a frame
    Canvas c{d.colour().empty() ? d.colourise(d.height()) : d.colour().clone(), frame_text(f.px), {}};
    for (const auto &p : d.trail_points()) cv::circle(c.img, cv::Point(cvRound(p.x), cvRound(p.y)), 1, cv::Scalar(120, 120, 120), cv::FILLED);
    const cv::Point2d tp = f.to_px(o.tip_nm[0], o.tip_nm[1]);
    const cv::Point tip(cvRound(tp.x), cvRound(tp.y));
    // the rings and glyphs first; then the text, each label where no other is
    draw_lever(c, tip, o, lever);
    const std::vector<cv::Rect> rings = draw_rings(c, f, model);
    draw_force_glyph(c, tip, o);
    draw_status(c, o);
    draw_colour_bar(c, d);
    draw_legend(c, o);
    draw_ids(c, f, model, rings);
    draw_axes(c, f);
    if (o.flags & fw_state_t::FLAG_INTERLOCK) draw_interlock(c);
    return c.img;
}

}  // namespace afm
