#include "fidelity.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

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

Fidelity compare_with_scan(const cv::Mat &displayed_nm, const cv::Mat &scan_nm, const Field &f,
                           const std::vector<DisplayObject> &model, const TipShape &tip, double search_nm)
{
    Fidelity out;
    cv::subtract(displayed_nm, scan_nm, out.diff_nm);
    out.rms_height_error_nm = std::sqrt(cv::mean(out.diff_nm.mul(out.diff_nm))[0]);
    for (const auto &p : model) {
        ObjectFidelity o{p.id, 0, 0, 0, 0, 0, false};
        // Look around the model position in both images with the same window.
        const double radius = sphere_footprint_nm(p.radius_nm, tip) * 0.5 + search_nm;
        const bool in_display = locate_bump(displayed_nm, f, p.x_nm, p.y_nm, radius, &o.display_x_nm, &o.display_y_nm);
        o.found = in_display && locate_bump(scan_nm, f, p.x_nm, p.y_nm, radius, &o.scan_x_nm, &o.scan_y_nm);
        o.error_nm = o.found ? std::hypot(o.display_x_nm - o.scan_x_nm, o.display_y_nm - o.scan_y_nm)
                             : std::numeric_limits<double>::infinity();
        out.max_position_error_nm = std::max(out.max_position_error_nm, o.error_nm);
        out.objects.push_back(o);
    }
    return out;
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
