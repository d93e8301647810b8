#include "fidelity_figure.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "frame_overlay.hpp"

namespace afm {

namespace {

const cv::Scalar kGrey(90, 90, 90);
constexpr std::size_t kMaxLabelled = 12;   // errors written beside at most this many objects: the unfound, then the worst
// The colour scale: the 95th percentile of the pixels that differ by more
// than kDiffFloor_nm (most pixels do not differ at all), at least kMinRange_nm.
constexpr double kDiffFloor_nm = 0.01, kDiffQuantile = 0.95, kMinRange_nm = 0.5;

// Blue (BGR 192, 76, 59) through white at 0 to red (38, 4, 180): v in [-1, 1].
cv::Vec3b diverging(double v)
{
    v = std::clamp(v, -1.0, 1.0);
    const cv::Vec3d end = v < 0 ? cv::Vec3d(192, 76, 59) : cv::Vec3d(38, 4, 180);
    const double a = std::fabs(v);
    cv::Vec3b out;
    for (int k = 0; k < 3; ++k) out[k] = cv::saturate_cast<uchar>(255 + (end[k] - 255) * a);
    return out;
}

// The error the check found for an object, as its label.
std::string error_label(const Fidelity &fid, const std::string &kind, int id)
{
    for (const auto &o : fid.objects)
        if (o.kind == kind && o.id == id) return o.found ? label_number("%.1f nm", o.error_nm) : "not found";
    return "not checked";
}

// The picture's labels: each beside its mark, in the first place around it
// that no earlier label or mark holds (its ink kTextGapPx round), inside the
// picture; none if every place is held.
struct Labels {
    cv::Mat img;
    FrameText t;
    std::vector<cv::Rect> taken;
    std::vector<TextBox> texts;

    void beside(const std::string &s, cv::Point c, int r)
    {
        const cv::Rect ink = ink_box(s, t.font_px, {0, 0});
        const int g = kTextGapPx + 1;
        const cv::Point tries[] = {{c.x + r + g - ink.x, c.y - ink.y - ink.height / 2},       {c.x - r - g - ink.br().x, c.y - ink.y - ink.height / 2},
                                   {c.x - ink.x - ink.width / 2, c.y + r + g - ink.y},       {c.x - ink.x - ink.width / 2, c.y - r - g - ink.br().y},
                                   {c.x + r + g - ink.x, c.y + r + g - ink.y},               {c.x - r - g - ink.br().x, c.y - r - g - ink.br().y}};
        for (const cv::Point &org : tries) {
            const cv::Rect box = ink + org, grown(box.x - kTextGapPx, box.y - kTextGapPx, box.width + 2 * kTextGapPx, box.height + 2 * kTextGapPx);
            if ((box & cv::Rect(0, 0, img.cols, img.rows)) != box ||
                std::any_of(taken.begin(), taken.end(), [&](const cv::Rect &o) { return (o & grown).area() > 0; }))
                continue;
            draw_text(img, s, org, t.font_px, kBlack);
            taken.push_back(box);
            texts.push_back({s, "id", box, t.font_px});
            return;
        }
    }
};

// The objects whose errors are written: those not found, then the worst,
// kMaxLabelled in all (fid.objects's kind and id).
std::vector<std::pair<std::string, int>> labelled(const Fidelity &fid)
{
    std::vector<const ObjectFidelity *> v;
    for (const auto &o : fid.objects) v.push_back(&o);
    std::stable_sort(v.begin(), v.end(), [](const ObjectFidelity *a, const ObjectFidelity *b) {
        if (a->found != b->found) return !a->found;
        return a->error_nm > b->error_nm;
    });
    std::vector<std::pair<std::string, int>> out;
    for (std::size_t i = 0; i < v.size() && i < kMaxLabelled; ++i) out.emplace_back(v[i]->kind, v[i]->id);
    return out;
}

// Each object outlined where the model has it (k: the enlargement), its
// error beside it; the labels drawn (picture coordinates).
std::vector<TextBox> outline_objects(cv::Mat &img, const Fidelity &fid, const Field &f, const DisplayModel &model, int k)
{
    auto at = [&](double x, double y) {
        const cv::Point2d q = f.to_px(x, y);
        return cv::Point(cvRound((q.x + 0.5) * k), cvRound((q.y + 0.5) * k));
    };
    Labels l{img, figure_text(), {}, {}};
    const std::vector<std::pair<std::string, int>> named = labelled(fid);
    auto is_named = [&](const char *kind, int id) { return std::find(named.begin(), named.end(), std::make_pair(std::string(kind), id)) != named.end(); };
    auto radius = [&](const DisplayObject &p) { return std::max(cvRound(p.radius_nm / f.pitch() * k) + 2, kMinMarkerPx / 2 * k); };
    for (const auto &p : model.particles) {
        const cv::Point c = at(p.x_nm, p.y_nm);
        const int r = radius(p);
        cv::circle(img, c, r, kBlack, 1, cv::LINE_AA);
        l.taken.push_back(cv::Rect(c.x - r, c.y - r, 2 * r + 1, 2 * r + 1));
    }
    for (const auto &p : model.particles)
        if (is_named("particle", p.id)) l.beside("p" + std::to_string(p.id) + " " + error_label(fid, "particle", p.id), at(p.x_nm, p.y_nm), radius(p));
    for (const auto &w : model.wires) {
        std::vector<cv::Point> pts;
        for (const auto &n : w.nodes_nm) pts.push_back(at(n.x, n.y));
        if (pts.empty()) continue;
        cv::polylines(img, pts, false, kBlack, 1, cv::LINE_AA);
        const int off = cvRound(w.diameter_nm / f.pitch() * k / 2) + 4;
        if (is_named("wire", w.id)) l.beside("w" + std::to_string(w.id) + " " + error_label(fid, "wire", w.id), pts[pts.size() / 2], off);
    }
    for (const auto &tr : model.trenches) {
        std::vector<cv::Point> pts;
        for (const auto &q : tr.points) pts.push_back(at(q.x_nm, q.y_nm));
        if (!pts.empty()) cv::polylines(img, pts, false, kGrey, 1, cv::LINE_AA);
    }
    return l.texts;
}

}  // namespace

double diff_range_nm(const cv::Mat &diff_nm)
{
    std::vector<float> a;
    for (int r = 0; r < diff_nm.rows; ++r)
        for (int c = 0; c < diff_nm.cols; ++c) {
            const float v = std::fabs(diff_nm.at<float>(r, c));
            if (std::isfinite(v) && v > kDiffFloor_nm) a.push_back(v);
        }
    double q = 0;
    if (!a.empty()) {
        const std::size_t i = std::min(a.size() - 1, static_cast<std::size_t>(kDiffQuantile * static_cast<double>(a.size())));
        std::nth_element(a.begin(), a.begin() + static_cast<std::ptrdiff_t>(i), a.end());
        q = a[i];
    }
    if (q <= kMinRange_nm) return kMinRange_nm;
    const double p = std::pow(10.0, std::floor(std::log10(q)));
    for (double m : {1.0, 2.0, 5.0, 10.0})
        if (q <= m * p) return m * p;
    return 10 * p;
}

cv::Mat fidelity_figure(const Fidelity &fid, const Field &f, const DisplayModel &model, double target_nm, FigureLayout *layout)
{
    const int side = frame_px(f.px), k = side / f.px;
    const double range = diff_range_nm(fid.diff_nm);
    const std::string title = label_number("display \u2212 fresh scan: worst object %.2f nm", fid.max_position_error_nm) + label_number(" (target %g nm)", target_nm);
    std::string second = label_number("rms height %.2f nm; colour saturates past \u00b1", fid.rms_height_error_nm) + label_number("%g nm", range);
    if (fid.objects.size() > kMaxLabelled) second += label_number("; errors of the %.0f worst", static_cast<double>(kMaxLabelled));
    cv::Mat diff(fid.diff_nm.size(), CV_8UC3);
    for (int r = 0; r < diff.rows; ++r)
        for (int c = 0; c < diff.cols; ++c) diff.at<cv::Vec3b>(r, c) = diverging(fid.diff_nm.at<float>(r, c) / range);
    cv::Mat big;
    cv::resize(diff, big, cv::Size(side, side), 0, 0, cv::INTER_NEAREST);
    const std::vector<TextBox> inner = outline_objects(big, fid, f, model, k);
    FigureBar bar;
    bar.lo = -range;
    bar.hi = range;
    bar.gradient = cv::Mat(101, 1, CV_8UC3);
    for (int i = 0; i <= 100; ++i) bar.gradient.at<cv::Vec3b>(i) = diverging(1.0 - i / 50.0);
    bar.ticks = {-range, -range / 2, 0, range / 2, range};
    bar.plus = true;
    return axes_figure(big, f, {title, second}, bar, inner, layout);
}

}  // namespace afm
