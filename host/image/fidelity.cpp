#include "fidelity.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>

namespace afm {

bool locate_bump(const cv::Mat &h_nm, const Field &f, double x_nm, double y_nm, double radius_nm, double *cx, double *cy)
{
    const cv::Point2d lo = f.to_px(x_nm - radius_nm, y_nm + radius_nm), hi = f.to_px(x_nm + radius_nm, y_nm - radius_nm);
    const cv::Rect r = cv::Rect(cv::Point(static_cast<int>(std::floor(lo.x)), static_cast<int>(std::floor(lo.y))),
                                cv::Point(static_cast<int>(std::ceil(hi.x)) + 1, static_cast<int>(std::ceil(hi.y)) + 1)) &
                       cv::Rect(0, 0, h_nm.cols, h_nm.rows);
    if (r.area() == 0) return false;
    double peak;
    cv::minMaxLoc(h_nm(r), nullptr, &peak);
    if (peak <= 1e-6) return false;
    const double floor_nm = 0.5 * peak;
    double sw = 0, sx = 0, sy = 0;
    for (int row = r.y; row < r.y + r.height; ++row) {
        const float *p = h_nm.ptr<float>(row);
        for (int col = r.x; col < r.x + r.width; ++col) {
            const double w = p[col] - floor_nm;
            if (w <= 0) continue;
            sw += w;
            sx += w * f.x_of(col);
            sy += w * f.y_of(row);
        }
    }
    if (sw <= 0) return false;
    *cx = sx / sw;
    *cy = sy / sw;
    return true;
}

bool locate_bump_centred(const cv::Mat &h_nm, const Field &f, double x_nm, double y_nm, double radius_nm, int passes, double *cx,
                         double *cy)
{
    double x = x_nm, y = y_nm;
    for (int i = 0; i < passes; ++i)
        if (!locate_bump(h_nm, f, x, y, radius_nm, &x, &y)) return false;
    *cx = x;
    *cy = y;
    return true;
}

bool nearest_bump(const cv::Mat &h_nm, const Field &f, double x_nm, double y_nm, double min_height_nm, double radius_nm,
                  const std::vector<cv::Point2d> &others, double skip_nm, double *cx, double *cy)
{
    cv::Mat high, labels, stats, centroids;
    cv::threshold(h_nm, high, min_height_nm, 255, cv::THRESH_BINARY);
    high.convertTo(high, CV_8U);
    const int n = cv::connectedComponentsWithStats(high, labels, stats, centroids, 8, CV_32S);
    double best = std::numeric_limits<double>::infinity(), bx = 0, by = 0;
    for (int i = 1; i < n; ++i) {
        const double x = f.x_of(0) + centroids.at<double>(i, 0) * f.pitch(), y = f.y_of(0) - centroids.at<double>(i, 1) * f.pitch();
        bool other = false;
        for (const auto &o : others) other = other || std::hypot(o.x - x, o.y - y) < skip_nm;
        const double d = std::hypot(x - x_nm, y - y_nm);
        if (!other && d < best) best = d, bx = x, by = y;
    }
    if (!std::isfinite(best)) return false;
    return locate_bump_centred(h_nm, f, bx, by, radius_nm, 3, cx, cy);
}

SitesCheck check_sites(const cv::Mat &scan_nm, const Field &f, const std::vector<cv::Point2d> &sites_nm, double search_nm,
                           double tolerance_nm)
{
    SitesCheck out;
    double sum2 = 0;
    int found = 0;
    for (const auto &s : sites_nm) {
        SiteCheck c{s.x, s.y};
        c.found = locate_bump_centred(scan_nm, f, s.x, s.y, search_nm, 3, &c.scan_x_nm, &c.scan_y_nm);
        if (c.found) {
            c.error_nm = std::hypot(c.scan_x_nm - s.x, c.scan_y_nm - s.y);
            out.placed += c.error_nm <= tolerance_nm;
            out.worst_nm = std::max(out.worst_nm, c.error_nm);
            sum2 += c.error_nm * c.error_nm;
            ++found;
        } else {
            ++out.missing;
        }
        out.sites.push_back(c);
    }
    out.rms_nm = found ? std::sqrt(sum2 / found) : 0;
    return out;
}

RodCheck check_rod(const cv::Mat &scan_nm, const Field &f, cv::Point2d centre_nm, double angle_deg, double length_nm, double band_nm)
{
    RodCheck out;
    const double a = angle_deg * M_PI / 180;
    const cv::Point2d half(0.5 * length_nm * std::cos(a), 0.5 * length_nm * std::sin(a));
    double cx = 0, cy = 0, ang = 0;
    out.found = locate_ridge(scan_nm, f, {centre_nm - half, centre_nm + half}, band_nm, &cx, &cy, &ang);
    if (!out.found) return out;
    double da = ang - std::fmod(std::fmod(a, M_PI) + M_PI, M_PI);
    if (da >= M_PI / 2) da -= M_PI;
    if (da < -M_PI / 2) da += M_PI;
    out.centroid_error_nm = std::hypot(cx - centre_nm.x, cy - centre_nm.y);
    out.angle_error_deg = da * 180 / M_PI;
    out.error_nm = out.centroid_error_nm + 0.5 * length_nm * std::fabs(std::sin(da));
    return out;
}

namespace {

// The polyline's point nearest q: its segment's index (a single node: 0),
// its distance from q and its arc length from the first node, nm (beyond an
// end, the arc length of q's projection on the end segment's line, so that
// the pixels beyond an end step on as the axis does).
struct Nearest {
    std::size_t segment = 0;
    double distance_nm = std::numeric_limits<double>::infinity(), along_nm = 0;
};
Nearest nearest_on_polyline(const std::vector<cv::Point2d> &nodes, const cv::Point2d &q)
{
    Nearest out;
    double s0 = 0;
    for (std::size_t i = 0; i < std::max<std::size_t>(1, nodes.size() - 1); ++i) {
        const cv::Point2d a = nodes[i], ab = nodes[std::min(i + 1, nodes.size() - 1)] - a;
        const double l2 = ab.dot(ab);
        const double u = l2 > 0 ? (q - a).dot(ab) / l2 : 0.0, t = std::clamp(u, 0.0, 1.0);
        const double d = std::hypot(q.x - a.x - t * ab.x, q.y - a.y - t * ab.y);
        // Beyond the first or the last node, the arc length runs on.
        const bool open_end = (i == 0 && u < 0) || (i + 2 >= nodes.size() && u > 1);
        if (d < out.distance_nm) out = {i, d, s0 + (open_end ? u : t) * std::sqrt(l2)};
        s0 += std::sqrt(l2);
    }
    return out;
}

// A segment's direction across its axis, binned to whole degrees in [0, 180)
// from +x, y up (a single node, or a segment of no length: 90).
int across_bin_deg(const std::vector<cv::Point2d> &nodes, std::size_t i)
{
    const cv::Point2d ab = nodes[std::min(i + 1, nodes.size() - 1)] - nodes[i];
    if (ab.dot(ab) <= 0) return 90;
    const int along = static_cast<int>(std::lround(std::atan2(ab.y, ab.x) * 180 / M_PI));
    return ((along + 90) % 180 + 180) % 180;
}

// A ridge's rise above the ground beside it, over the pixels r, for the
// direction across its axis `across_deg` (degrees from +x, y up): the image
// less its opening by a line of half-length band_nm in that direction (a
// 1-D white top-hat across the axis). The opening removes what is narrower
// than the line across it (a wire's image, whose footprint the band holds)
// and keeps what is wider or hollow (the flat substrate, a V-groove, a
// groove's end), so a rod seated in a groove, its top below the substrate,
// rises above the groove's walls as a rod on the flat rises above 0; and its
// end, which a disc would set against the groove's floor beyond it, rises
// only as its cross-section does. Computed on r widened by the line, so r's
// edges see their ground.
cv::Mat ridge_rise(const cv::Mat &h_nm, const Field &f, const cv::Rect &r, double band_nm, int across_deg)
{
    const int rad = std::max(1, static_cast<int>(std::ceil(band_nm / f.pitch())));
    const cv::Rect wide = cv::Rect(r.x - rad, r.y - rad, r.width + 2 * rad, r.height + 2 * rad) & cv::Rect(0, 0, h_nm.cols, h_nm.rows);
    // The line in pixels: columns run with +x, rows against +y.
    const double a = across_deg * M_PI / 180;
    const cv::Point2d end(rad * std::cos(a), -rad * std::sin(a));
    cv::Mat line(2 * rad + 1, 2 * rad + 1, CV_8U, cv::Scalar(0));
    cv::line(line, cv::Point(cvRound(rad - end.x), cvRound(rad - end.y)), cv::Point(cvRound(rad + end.x), cvRound(rad + end.y)),
             cv::Scalar(1), 1, cv::LINE_8);
    cv::Mat open;
    cv::morphologyEx(h_nm(wide), open, cv::MORPH_OPEN, line);
    cv::Mat rise = h_nm(wide) - open;
    return rise(cv::Rect(r.x - wide.x, r.y - wide.y, r.width, r.height)).clone();
}

double polyline_length(const std::vector<cv::Point2d> &nodes)
{
    double L = 0;
    for (std::size_t i = 0; i + 1 < nodes.size(); ++i) L += std::hypot(nodes[i + 1].x - nodes[i].x, nodes[i + 1].y - nodes[i].y);
    return L;
}

}  // namespace

bool locate_ridge(const cv::Mat &h_nm, const Field &f, const std::vector<cv::Point2d> &nodes_nm, double band_nm,
                  double *cx, double *cy, double *angle_rad)
{
    if (nodes_nm.empty()) return false;
    double xlo = nodes_nm[0].x, xhi = xlo, ylo = nodes_nm[0].y, yhi = ylo;
    for (const auto &p : nodes_nm) {
        xlo = std::min(xlo, p.x);
        xhi = std::max(xhi, p.x);
        ylo = std::min(ylo, p.y);
        yhi = std::max(yhi, p.y);
    }
    const cv::Point2d lo = f.to_px(xlo - band_nm, yhi + band_nm), hi = f.to_px(xhi + band_nm, ylo - band_nm);
    const cv::Rect r = cv::Rect(cv::Point(static_cast<int>(std::floor(lo.x)), static_cast<int>(std::floor(lo.y))),
                                cv::Point(static_cast<int>(std::ceil(hi.x)) + 1, static_cast<int>(std::ceil(hi.y)) + 1)) &
                       cv::Rect(0, 0, h_nm.cols, h_nm.rows);
    if (r.area() == 0) return false;
    // The band: pixels within band_nm of the polyline, each with the rise
    // across its nearest segment (one opening per direction met), and the
    // highest rise at each pixel step along the polyline.
    std::map<int, cv::Mat> rise_across;
    std::map<int, float> crest;
    cv::Mat rise(r.size(), CV_32F, cv::Scalar(0)), step_of(r.size(), CV_32S, cv::Scalar(0)), in_band(r.size(), CV_8U, cv::Scalar(0));
    for (int row = r.y; row < r.y + r.height; ++row)
        for (int col = r.x; col < r.x + r.width; ++col) {
            const Nearest n = nearest_on_polyline(nodes_nm, {f.x_of(col), f.y_of(row)});
            if (n.distance_nm > band_nm) continue;
            const int bin = across_bin_deg(nodes_nm, n.segment);
            auto it = rise_across.find(bin);
            if (it == rise_across.end()) it = rise_across.emplace(bin, ridge_rise(h_nm, f, r, band_nm, bin)).first;
            const float v = it->second.at<float>(row - r.y, col - r.x);
            rise.at<float>(row - r.y, col - r.x) = v;
            in_band.at<uchar>(row - r.y, col - r.x) = 1;
            const int step = static_cast<int>(std::lround(n.along_nm / f.pitch()));
            step_of.at<int>(row - r.y, col - r.x) = step;
            crest[step] = std::max(crest[step], v);
        }
    // The ridge's height: the median of its crest over the steps where it
    // rises at all, so that a feature a few pixels long neither sets the
    // threshold nor outweighs the ridge's length. A step whose crest is over
    // twice that is not the ridge's body but something set against a deeper
    // floor (a seated rod's end over the groove's bottom, whose image the
    // tip's shape sets more than the rod's place) and is left out; each
    // other pixel weighs its rise clipped at the ridge's height.
    std::vector<float> crests;
    for (const auto &[step, c] : crest)
        if (c > 1e-6f) crests.push_back(c);
    if (crests.empty()) return false;
    std::nth_element(crests.begin(), crests.begin() + crests.size() / 2, crests.end());
    const double peak = crests[crests.size() / 2];
    if (peak <= 1e-6) return false;
    const double floor_nm = 0.5 * peak;
    double sw = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    for (int row = r.y; row < r.y + r.height; ++row)
        for (int col = r.x; col < r.x + r.width; ++col) {
            const double w = std::min<double>(rise.at<float>(row - r.y, col - r.x), peak) - floor_nm;
            if (w <= 0 || !in_band.at<uchar>(row - r.y, col - r.x) || crest[step_of.at<int>(row - r.y, col - r.x)] > 2 * peak) continue;
            const double x = f.x_of(col), y = f.y_of(row);
            sw += w;
            sx += w * x;
            sy += w * y;
            sxx += w * x * x;
            syy += w * y * y;
            sxy += w * x * y;
        }
    if (sw <= 0) return false;
    *cx = sx / sw;
    *cy = sy / sw;
    const double vxx = sxx / sw - *cx * *cx, vyy = syy / sw - *cy * *cy, vxy = sxy / sw - *cx * *cy;
    double a = 0.5 * std::atan2(2 * vxy, vxx - vyy);
    if (a < 0) a += M_PI;
    *angle_rad = a;
    return true;
}

Fidelity compare_with_scan(const cv::Mat &displayed_nm, const cv::Mat &scan_nm, const Field &f, const DisplayModel &model,
                           const TipShape &tip, double search_nm)
{
    Fidelity out;
    cv::subtract(displayed_nm, scan_nm, out.diff_nm);
    out.rms_height_error_nm = std::sqrt(cv::mean(out.diff_nm.mul(out.diff_nm))[0]);
    for (const auto &p : model.particles) {
        ObjectFidelity o{"particle", p.id, 0, 0, 0, 0, 0, false};
        // Look around the model position in both images with the same window.
        const double radius = sphere_footprint_nm(p.radius_nm, tip) * 0.5 + search_nm;
        const bool in_display = locate_bump(displayed_nm, f, p.x_nm, p.y_nm, radius, &o.display_x_nm, &o.display_y_nm);
        o.found = in_display && locate_bump(scan_nm, f, p.x_nm, p.y_nm, radius, &o.scan_x_nm, &o.scan_y_nm);
        o.error_nm = o.found ? std::hypot(o.display_x_nm - o.scan_x_nm, o.display_y_nm - o.scan_y_nm)
                             : std::numeric_limits<double>::infinity();
        out.max_position_error_nm = std::max(out.max_position_error_nm, o.error_nm);
        out.objects.push_back(o);
    }
    for (const auto &w : model.wires) {
        ObjectFidelity o{"wire", w.id, 0, 0, 0, 0, 0, false};
        // The band around the model's axis holds the whole imaged wire even
        // when the scan shows it search_nm away.
        const double band = wire_footprint_nm(0.5 * w.diameter_nm, tip) + search_nm;
        double a_display = 0, a_scan = 0;
        const bool in_display = locate_ridge(displayed_nm, f, w.nodes_nm, band, &o.display_x_nm, &o.display_y_nm, &a_display);
        o.found = in_display && locate_ridge(scan_nm, f, w.nodes_nm, band, &o.scan_x_nm, &o.scan_y_nm, &a_scan);
        if (o.found) {
            double da = a_scan - a_display;
            if (da >= M_PI / 2) da -= M_PI;
            if (da < -M_PI / 2) da += M_PI;
            o.display_angle_deg = a_display * 180 / M_PI;
            o.scan_angle_deg = a_scan * 180 / M_PI;
            o.angle_error_deg = da * 180 / M_PI;
            o.centroid_error_nm = std::hypot(o.display_x_nm - o.scan_x_nm, o.display_y_nm - o.scan_y_nm);
            o.error_nm = o.centroid_error_nm + 0.5 * polyline_length(w.nodes_nm) * std::fabs(std::sin(da));
            out.max_angle_error_deg = std::max(out.max_angle_error_deg, std::fabs(o.angle_error_deg));
        } else {
            o.error_nm = std::numeric_limits<double>::infinity();
        }
        out.max_position_error_nm = std::max(out.max_position_error_nm, o.error_nm);
        out.objects.push_back(o);
    }
    return out;
}

Fidelity compare_with_scan(const cv::Mat &displayed_nm, const cv::Mat &scan_nm, const Field &f,
                           const std::vector<DisplayObject> &model, const TipShape &tip, double search_nm)
{
    return compare_with_scan(displayed_nm, scan_nm, f, DisplayModel{model, {}, {}}, tip, search_nm);
}

cv::Mat diff_image(const cv::Mat &diff_nm, double range_nm)
{
    cv::Mat img(diff_nm.size(), CV_8UC3);
    for (int r = 0; r < diff_nm.rows; ++r)
        for (int c = 0; c < diff_nm.cols; ++c) {
            const double v = std::clamp(diff_nm.at<float>(r, c) / range_nm, -1.0, 1.0);
            const uchar fade = static_cast<uchar>(std::lround(255 * (1 - std::fabs(v))));
            img.at<cv::Vec3b>(r, c) = v >= 0 ? cv::Vec3b(fade, fade, 255) : cv::Vec3b(255, fade, fade);
        }
    return img;
}

}  // namespace afm
