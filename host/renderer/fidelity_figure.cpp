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

const cv::Scalar kBlack(0, 0, 0), kGrey(90, 90, 90);
constexpr int kMinSidePx = 512;
constexpr std::size_t kMaxLabelled = 12;   // errors written beside at most this many objects: the unfound, then the worst
// The colour scale: the 95th percentile of the pixels that differ by more
// than kDiffFloor_nm (most pixels do not differ at all), at least kMinRange_nm.
constexpr double kDiffFloor_nm = 0.01, kDiffQuantile = 0.95, kMinRange_nm = 0.5;
constexpr double kTextScale = 1.3;   // cv::FONT_HERSHEY_PLAIN: a capital 12 px high or more, shown at 100 %

}  // namespace

FrameText fidelity_figure_text()
{
    int base = 0;
    FrameText t;
    t.scale = kTextScale;
    t.cap_px = cv::getTextSize("H", cv::FONT_HERSHEY_PLAIN, t.scale, 1, &base).height;
    t.line_px = t.cap_px + 8;
    return t;
}

namespace {

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

std::string fmt(const char *f, double v)
{
    char b[96];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

void text(cv::Mat &img, const std::string &s, cv::Point org, double scale, const cv::Scalar &c = kBlack)
{
    cv::putText(img, s, org, cv::FONT_HERSHEY_PLAIN, scale, c, 1, cv::LINE_AA);
}

// The colour bar, right of the image: +range at the top, -range at the bottom, ticks in nm.
void colour_bar(cv::Mat &img, cv::Rect bar, double range, const FrameText &t)
{
    for (int y = 0; y < bar.height; ++y)
        img(cv::Rect(bar.x, bar.y + y, bar.width, 1)).setTo(diverging(1.0 - 2.0 * y / (bar.height - 1)));
    cv::rectangle(img, bar, kBlack, 1);
    for (int i = -2; i <= 2; ++i) {
        const int y = bar.y + cvRound((bar.height - 1) * (2 - i) / 4.0);
        cv::line(img, cv::Point(bar.br().x, y), cv::Point(bar.br().x + 4, y), kBlack, 1);
        text(img, fmt("%+g", range * i / 2.0).replace(0, i == 0 ? 1 : 0, ""), cv::Point(bar.br().x + 7, y + t.cap_px / 2), t.scale);
    }
    text(img, "nm", cv::Point(bar.x, bar.y - t.line_px / 2), t.scale);
}

// The error the check found for an object, as its label.
std::string error_label(const Fidelity &fid, const std::string &kind, int id)
{
    for (const auto &o : fid.objects)
        if (o.kind == kind && o.id == id) return o.found ? fmt("%.1f nm", o.error_nm) : "not found";
    return "not checked";
}

// A label beside a mark of radius r at c, in the first place around it
// that no earlier label or mark holds (taken), inside the image; none if
// every place is held.
void place_label(cv::Mat &img, const std::string &s, cv::Point c, int r, const FrameText &t, std::vector<cv::Rect> *taken)
{
    int base = 0;
    const cv::Size sz = cv::getTextSize(s, cv::FONT_HERSHEY_PLAIN, t.scale, 1, &base);
    const cv::Point tries[] = {{r + 3, -r / 2}, {r + 3, r + sz.height}, {-r - 3 - sz.width, -r / 2}, {-r - 3 - sz.width, r + sz.height},
                               {-sz.width / 2, r + sz.height + 4}, {-sz.width / 2, -r - 4}};
    for (const cv::Point &d : tries) {
        const cv::Rect box(c.x + d.x - 2, c.y + d.y - sz.height - 2, sz.width + 4, sz.height + 6);
        if ((box & cv::Rect(0, 0, img.cols, img.rows)) != box ||
            std::any_of(taken->begin(), taken->end(), [&](const cv::Rect &o) { return (o & box).area() > 0; }))
            continue;
        taken->push_back(box);
        text(img, s, cv::Point(box.x + 2, box.y + sz.height + 2), t.scale);
        return;
    }
}

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

// Each object outlined where the model has it (k: the enlargement), its error beside it.
void outline_objects(cv::Mat &img, const Fidelity &fid, const Field &f, const DisplayModel &model, int k, const FrameText &t)
{
    auto at = [&](double x, double y) {
        const cv::Point2d q = f.to_px(x, y);
        return cv::Point(cvRound((q.x + 0.5) * k), cvRound((q.y + 0.5) * k));
    };
    std::vector<cv::Rect> taken;
    const std::vector<std::pair<std::string, int>> named = labelled(fid);
    auto is_named = [&](const char *kind, int id) { return std::find(named.begin(), named.end(), std::make_pair(std::string(kind), id)) != named.end(); };
    for (const auto &p : model.particles) {
        const cv::Point c = at(p.x_nm, p.y_nm);
        const int r = std::max(cvRound(p.radius_nm / f.pitch() * k) + 2, kMinMarkerPx / 2 * k);
        cv::circle(img, c, r, kBlack, 1, cv::LINE_AA);
        taken.push_back(cv::Rect(c.x - r, c.y - r, 2 * r + 1, 2 * r + 1));
    }
    for (const auto &p : model.particles) {
        if (!is_named("particle", p.id)) continue;
        const int r = std::max(cvRound(p.radius_nm / f.pitch() * k) + 2, kMinMarkerPx / 2 * k);
        place_label(img, "p" + std::to_string(p.id) + " " + error_label(fid, "particle", p.id), at(p.x_nm, p.y_nm), r, t, &taken);
    }
    for (const auto &w : model.wires) {
        std::vector<cv::Point> pts;
        for (const auto &n : w.nodes_nm) pts.push_back(at(n.x, n.y));
        if (pts.empty()) continue;
        cv::polylines(img, pts, false, kBlack, 1, cv::LINE_AA);
        const int off = cvRound(w.diameter_nm / f.pitch() * k / 2) + 4;
        if (is_named("wire", w.id))
            place_label(img, "w" + std::to_string(w.id) + " " + error_label(fid, "wire", w.id), pts[pts.size() / 2], off, t, &taken);
    }
    for (const auto &tr : model.trenches) {
        std::vector<cv::Point> pts;
        for (const auto &q : tr.points) pts.push_back(at(q.x_nm, q.y_nm));
        if (!pts.empty()) cv::polylines(img, pts, false, kGrey, 1, cv::LINE_AA);
    }
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

cv::Mat fidelity_figure(const Fidelity &fid, const Field &f, const DisplayModel &model, double target_nm)
{
    const int k = std::max(1, (kMinSidePx + f.px - 1) / f.px), side = f.px * k;
    const FrameText t = fidelity_figure_text();
    const double range = diff_range_nm(fid.diff_nm);
    int base = 0, label_w = 0;
    for (double v : {range / 2, range}) label_w = std::max(label_w, cv::getTextSize(fmt("%+g", v), cv::FONT_HERSHEY_PLAIN, t.scale, 1, &base).width);
    const std::string title = fmt("display - fresh scan: worst object %.2f nm", fid.max_position_error_nm) + fmt(" (target %g nm)", target_nm);
    std::string second = fmt("rms height %.2f nm; colour saturates past ", fid.rms_height_error_nm) + fmt("+-%g nm", range);
    if (fid.objects.size() > kMaxLabelled) second += fmt("; errors of the %.0f worst", static_cast<double>(kMaxLabelled));
    const int title_w = std::max(cv::getTextSize(title, cv::FONT_HERSHEY_PLAIN, t.scale, 1, &base).width,
                                 cv::getTextSize(second, cv::FONT_HERSHEY_PLAIN, t.scale, 1, &base).width);
    const int bw = 2 * t.line_px, top = 3 * t.line_px, right = 2 * t.line_px + bw + 12 + label_w + 8;
    cv::Mat img(side + top + t.line_px, std::max(side + right, title_w + 12), CV_8UC3, cv::Scalar(255, 255, 255));
    cv::Mat diff(fid.diff_nm.size(), CV_8UC3);
    for (int r = 0; r < diff.rows; ++r)
        for (int c = 0; c < diff.cols; ++c) diff.at<cv::Vec3b>(r, c) = diverging(fid.diff_nm.at<float>(r, c) / range);
    cv::Mat big;
    cv::resize(diff, big, cv::Size(side, side), 0, 0, cv::INTER_NEAREST);
    cv::Mat area = img(cv::Rect(0, top, side, side));
    big.copyTo(area);
    outline_objects(area, fid, f, model, k, t);
    cv::rectangle(img, cv::Rect(0, top, side, side), kBlack, 1);
    text(img, title, cv::Point(4, t.line_px), t.scale);
    text(img, second, cv::Point(4, 2 * t.line_px), t.scale);
    colour_bar(img, cv::Rect(side + 2 * t.line_px, top + 2 * t.line_px, bw, side - 4 * t.line_px), range, t);
    return img;
}

}  // namespace afm
