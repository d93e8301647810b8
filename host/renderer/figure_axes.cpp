#include "figure_axes.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace afm {

namespace {

constexpr int kFigureFontPx = 15;   // DejaVu Sans: a capital 11 px high
constexpr int kPad = 10;            // the figure's margin

// The figure's texts, each where its ink (kTextGapPx round) meets no other text
// or tick, inside the figure.
struct Page {
    cv::Mat img;
    FrameText t;
    FigureLayout out;
    std::vector<cv::Rect> taken;

    cv::Rect ink(const std::string &s, cv::Point org = {0, 0}) const { return ink_box(s, t.font_px, org); }
    bool put(const std::string &s, cv::Point org, const char *role)
    {
        const cv::Rect r = ink(s, org), g(r.x - kTextGapPx, r.y - kTextGapPx, r.width + 2 * kTextGapPx, r.height + 2 * kTextGapPx);
        if ((r & cv::Rect(0, 0, img.cols, img.rows)) != r) return false;
        if (std::any_of(taken.begin(), taken.end(), [&](const cv::Rect &o) { return (o & g).area() > 0; })) return false;
        draw_text(img, s, org, t.font_px, kBlack);
        taken.push_back(r);
        out.texts.push_back({s, role, r, t.font_px});
        return true;
    }
    void mark(cv::Point p, cv::Point q)
    {
        cv::line(img, p, q, kBlack, 1);
        const cv::Rect r(std::min(p.x, q.x), std::min(p.y, q.y), std::abs(q.x - p.x) + 1, std::abs(q.y - p.y) + 1);
        taken.push_back(r);
        out.axes.push_back(r);
    }
};

std::string bar_label(double v, bool plus)
{
    const std::string s = axis_number(v);
    return plus && v > 0 ? "+" + s : s;
}

// The figure's size round a picture of side S: margins for the title, the axes and the bar.
struct Margins {
    int left, top, right, bottom, T, gap, bar_w;
};

Margins margins(const Page &p, const Field &f, std::size_t title_lines, const FigureBar &bar)
{
    Margins m;
    m.T = 6;
    m.gap = 4;
    m.bar_w = 2 * p.t.line_px;
    int y_w = 0, bar_lw = p.ink(bar.unit).width;
    for (double v : round_ticks(f.y0_nm, f.y0_nm + f.size_nm)) y_w = std::max(y_w, p.ink(axis_number(v)).width);
    for (double v : bar.ticks) bar_lw = std::max(bar_lw, p.ink(bar_label(v, bar.plus)).width);
    m.left = kPad + std::max(y_w + m.gap + m.T, p.ink("y (nm)").width / 2);
    m.top = kPad + static_cast<int>(title_lines + 1) * p.t.line_px + m.gap + p.t.cap_px / 2 + 2 * kTextGapPx + 2;
    m.right = 2 * p.t.line_px + m.bar_w + m.T + m.gap + bar_lw + kPad;
    m.bottom = m.T + m.gap + 2 * p.t.line_px + kPad;
    return m;
}

// The axes in nm round the picture at `pic`: ticks out of it, labels beyond.
void draw_axes(Page &p, const cv::Rect &pic, const Field &f, const Margins &m)
{
    const double px_per_nm = pic.width / f.size_nm;
    const int base = pic.br().y + m.T + m.gap + p.t.cap_px;
    for (double v : round_ticks(f.x0_nm, f.x0_nm + f.size_nm)) {
        const int col = std::min(pic.br().x - 1, pic.x + cvRound((v - f.x0_nm) * px_per_nm));
        p.mark({col, pic.br().y}, {col, pic.br().y + m.T - 1});
        const std::string s = axis_number(v);
        const cv::Rect r = p.ink(s);
        p.put(s, {col - r.x - r.width / 2, base}, "x tick");
    }
    for (double v : round_ticks(f.y0_nm, f.y0_nm + f.size_nm)) {
        const int row = std::min(pic.br().y - 1, pic.br().y - 1 - cvRound((v - f.y0_nm) * px_per_nm));
        p.mark({pic.x - m.T, row}, {pic.x - 1, row});
        const std::string s = axis_number(v);
        const cv::Rect r = p.ink(s);
        p.put(s, {pic.x - m.T - m.gap - r.br().x, row - r.y - r.height / 2}, "y tick");
    }
    const cv::Rect xr = p.ink("x (nm)"), yr = p.ink("y (nm)");
    p.put("x (nm)", {pic.x + pic.width / 2 - xr.x - xr.width / 2, base + p.t.line_px}, "axis unit");
    // above the top tick's label, which may stand half over the picture's top
    p.put("y (nm)", {std::max(0, pic.x - yr.width / 2) - yr.x, pic.y - p.t.cap_px / 2 - 2 * kTextGapPx - 2 - yr.br().y}, "axis unit");
}

// The colour bar right of the picture, its ticks and labels, the unit above it.
void draw_bar(Page &p, const cv::Rect &pic, const FigureBar &bar, const Margins &m)
{
    const cv::Rect b(pic.br().x + 2 * p.t.line_px, pic.y + p.t.line_px, m.bar_w, pic.height - 2 * p.t.line_px);
    cv::Mat strip;
    cv::resize(bar.gradient, strip, b.size(), 0, 0, cv::INTER_LINEAR);
    strip.copyTo(p.img(b));
    cv::rectangle(p.img, b, kBlack, 1);
    p.taken.push_back(b);
    for (double v : bar.ticks) {
        const int y = b.y + cvRound((b.height - 1) * (bar.hi - v) / (bar.hi - bar.lo));
        p.mark({b.br().x, y}, {b.br().x + m.T - 1, y});
        const std::string s = bar_label(v, bar.plus);
        const cv::Rect r = p.ink(s);
        p.put(s, {b.br().x + m.T + m.gap - r.x, y - r.y - r.height / 2}, "bar");
    }
    const cv::Rect u = p.ink(bar.unit);
    p.put(bar.unit, {b.x - u.x, b.y - m.gap - kTextGapPx - 1 - u.br().y}, "bar");
}

}  // namespace

FrameText figure_text()
{
    FrameText t;
    t.font_px = kFigureFontPx;
    t.cap_px = cap_height_px(t.font_px);
    t.line_px = t.font_px + 6;
    return t;
}

std::vector<double> round_ticks(double lo, double hi)
{
    std::vector<double> v;
    const double span = hi - lo;
    if (!(span > 0)) return v;
    const double p = std::pow(10.0, std::floor(std::log10(span / 4)));
    double step = 10 * p;
    for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
        if (span / (m * p) <= 6) {
            step = m * p;
            break;
        }
    for (double x = std::ceil(lo / step - 1e-9) * step; x <= hi + 1e-9 * step; x += step) v.push_back(std::fabs(x) < 1e-9 * step ? 0.0 : x);
    return v;
}

cv::Mat axes_figure(const cv::Mat &picture, const Field &f, const std::vector<std::string> &title, const FigureBar &bar,
                    const std::vector<TextBox> &inner, FigureLayout *layout)
{
    Page p{cv::Mat(), figure_text(), {}, {}};
    const int S = picture.cols;
    const Margins m = margins(p, f, title.size(), bar);
    int title_w = 0;
    for (const auto &s : title) title_w = std::max(title_w, p.ink(s).br().x);
    p.img = cv::Mat(m.top + S + m.bottom, std::max(m.left + S + m.right, kPad + title_w + kPad), CV_8UC3, cv::Scalar(255, 255, 255));
    const cv::Rect pic(m.left, m.top, S, S);
    picture.copyTo(p.img(pic));
    for (const TextBox &t : inner) {
        p.out.texts.push_back({t.text, t.role, t.ink + pic.tl(), t.font_px});
        p.taken.push_back(t.ink + pic.tl());
    }
    p.taken.push_back(pic);
    const cv::Rect border(pic.x - 1, pic.y - 1, S + 2, S + 2);
    cv::rectangle(p.img, border, kBlack, 1);
    for (const cv::Rect &line : {cv::Rect(border.x, border.y, border.width, 1), cv::Rect(border.x, border.br().y - 1, border.width, 1),
                                 cv::Rect(border.x, border.y, 1, border.height), cv::Rect(border.br().x - 1, border.y, 1, border.height)}) {
        p.out.axes.push_back(line);
        p.taken.push_back(line);
    }
    for (std::size_t i = 0; i < title.size(); ++i)
        p.put(title[i], {kPad, kPad + p.t.cap_px + static_cast<int>(i) * p.t.line_px}, "title");
    draw_axes(p, pic, f, m);
    draw_bar(p, pic, bar, m);
    p.out.picture = pic;
    if (layout) *layout = std::move(p.out);
    return p.img;
}

cv::Mat scan_figure(const Display &d, const cv::Mat &scan_nm, const std::string &title, FigureLayout *layout)
{
    const Field &f = d.field();
    const int S = frame_px(f.px);
    cv::Mat pic;
    cv::resize(d.colourise(scan_nm), pic, cv::Size(S, S), 0, 0, cv::INTER_NEAREST);
    FigureBar bar;
    bar.lo = d.z_bottom();
    bar.hi = d.z_top();
    cv::Mat h(256, 1, CV_32F);
    for (int i = 0; i < h.rows; ++i) h.at<float>(i) = static_cast<float>(bar.hi - (bar.hi - bar.lo) * i / (h.rows - 1));
    bar.gradient = d.colourise(h);
    bar.ticks = round_ticks(bar.lo, bar.hi);
    char b[160];
    std::snprintf(b, sizeof b, "field %g \u00d7 %g nm, %d \u00d7 %d px (%.3g nm a pixel)", f.size_nm, f.size_nm, f.px, f.px, f.pitch());
    return axes_figure(pic, f, {title, b}, bar, {}, layout);
}

}  // namespace afm
