#include "pattern.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "png_read.hpp"

namespace afm {

namespace {

constexpr int kPxPerPitch = 16;   // a PNG mask's rasterisation: pixels per pitch

// Sites from a coverage image (1 = pattern) whose pixel is pitch / kPxPerPitch
// nm: one per grid cell covered at least half; the image's centre at `c`.
std::vector<Vec2> sample_cells(const cv::Mat &cover, double pitch_nm, Vec2 c)
{
    cv::Mat cells;
    cv::resize(cover, cells, cv::Size(std::max(1, cover.cols / kPxPerPitch), std::max(1, cover.rows / kPxPerPitch)), 0, 0,
               cv::INTER_AREA);
    std::vector<Vec2> out;
    for (int r = 0; r < cells.rows; ++r)
        for (int k = 0; k < cells.cols; ++k)
            if (cells.at<float>(r, k) >= 0.5f)
                out.push_back({c.x + (k + 0.5 - cells.cols / 2.0) * pitch_nm, c.y + (cells.rows / 2.0 - r - 0.5) * pitch_nm});
    return out;
}

std::vector<Vec2> text_sites(const TargetSpec &t)
{
    // Drawn at one pixel per site, one pixel thick: the strokes are rows
    // and columns of sites, as a dot-matrix display draws letters.
    const int font = cv::FONT_HERSHEY_SIMPLEX, rows = std::max(3, static_cast<int>(std::lround(t.height_nm / t.pitch_nm)));
    int base = 0;
    const cv::Size one = cv::getTextSize(t.text, font, 1.0, 1, &base);
    const double scale = static_cast<double>(rows - 1) / std::max(1, one.height);
    const cv::Size sz = cv::getTextSize(t.text, font, scale, 1, &base);
    cv::Mat img = cv::Mat::zeros(sz.height + 4, sz.width + 4, CV_8U);
    cv::putText(img, t.text, cv::Point(2, 2 + sz.height), font, scale, cv::Scalar(255), 1, cv::LINE_8);
    std::vector<Vec2> out;
    for (int r = 0; r < img.rows; ++r)
        for (int k = 0; k < img.cols; ++k)
            if (img.at<uchar>(r, k))
                out.push_back({t.center_nm.x + (k + 0.5 - img.cols / 2.0) * t.pitch_nm, t.center_nm.y + (img.rows / 2.0 - r - 0.5) * t.pitch_nm});
    return out;
}

std::vector<Vec2> png_sites(const Scene &s)
{
    const TargetSpec &t = s.targets;
    const cv::Mat grey = read_png(t.png, false);
    if (grey.empty()) throw PatternError(s.file + ": objects.targets.png: cannot read the image '" + t.png + "'");
    const double px_per_nm = kPxPerPitch / t.pitch_nm;
    const int rows = std::max(kPxPerPitch, static_cast<int>(std::lround(t.height_nm * px_per_nm / kPxPerPitch)) * kPxPerPitch);
    const int cols = std::max(kPxPerPitch, static_cast<int>(std::lround(rows * grey.cols / static_cast<double>(grey.rows) / kPxPerPitch)) *
                                               kPxPerPitch);
    cv::Mat g, cover;
    cv::resize(grey, g, cv::Size(cols, rows), 0, 0, cv::INTER_AREA);
    cv::threshold(g, cover, 127, 1, cv::THRESH_BINARY_INV);
    cover.convertTo(cover, CV_32F);
    return sample_cells(cover, t.pitch_nm, t.center_nm);
}

}  // namespace

std::vector<Vec2> target_sites(const Scene &s)
{
    const TargetSpec &t = s.targets;
    std::vector<Vec2> out;
    std::string key = "objects.targets";
    if (!t.sites_nm.empty()) out = t.sites_nm;
    else if (!t.text.empty()) out = text_sites(t), key += ".text";
    else if (!t.png.empty()) out = png_sites(s), key += ".png";
    else return out;
    if (out.empty()) throw PatternError(s.file + ": " + key + ": the pattern gives no sites at pitch_nm " + std::to_string(t.pitch_nm));
    const double half = s.field_nm / 2;
    for (const Vec2 &v : out)
        if (std::fabs(v.x - s.field_center_nm.x) > half || std::fabs(v.y - s.field_center_nm.y) > half) {
            std::ostringstream m;
            m << s.file << ": " << key << ": a site at (" << v.x << ", " << v.y << ") nm lies outside the field: give a smaller height_nm or pitch_nm";
            throw PatternError(m.str());
        }
    return out;
}

std::string targets_refusal(const Scene &s)
{
    try {
        const std::vector<Vec2> sites = target_sites(s);
        if (sites.size() > s.particles.size()) {
            std::ostringstream m;
            m << s.file << ": objects.targets: " << sites.size() << " sites but the scene has only " << s.particles.size()
              << " particles: give more particles (objects.scatter.count) or fewer sites";
            return m.str();
        }
        // Two sites closer than a particle's diameter and the clearance cannot both hold one.
        double r = 0;
        for (const auto &p : s.particles) r = std::max(r, p.radius_nm);
        const double need = 2 * r + s.op.plan.clearance_nm;
        for (std::size_t i = 0; i < sites.size(); ++i)
            for (std::size_t j = i + 1; j < sites.size(); ++j)
                if (std::hypot(sites[i].x - sites[j].x, sites[i].y - sites[j].y) < need) {
                    std::ostringstream m;
                    m << s.file << ": objects.targets: the sites (" << sites[i].x << ", " << sites[i].y << ") and (" << sites[j].x << ", "
                      << sites[j].y << ") nm are closer than a particle's diameter and operator.plan.clearance_nm (" << need
                      << " nm): give a larger pitch_nm";
                    return m.str();
                }
    } catch (const PatternError &e) {
        return e.what();
    }
    return "";
}

}  // namespace afm
