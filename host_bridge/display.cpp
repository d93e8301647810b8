#include "display.hpp"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "afm/fw_force_t.hpp"

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
const cv::Scalar kWhite(255, 255, 255), kCyan(255, 255, 0), kTip(255, 200, 0), kYellow(0, 255, 255);

}  // namespace

Display::Display(const Field &f, const TipShape &tip) : f_(f), tip_(tip), lut_(afmhot_lut()) {}

cv::Rect Display::footprint(const DisplayObject &p) const
{
    const double r = sphere_footprint_nm(p.radius_nm, tip_) + f_.pitch();
    const cv::Point2d lo = f_.to_px(p.x_nm - r, p.y_nm + r), hi = f_.to_px(p.x_nm + r, p.y_nm - r);
    const int c0 = static_cast<int>(std::floor(lo.x)), r0 = static_cast<int>(std::floor(lo.y));
    const int c1 = static_cast<int>(std::ceil(hi.x)), r1 = static_cast<int>(std::ceil(hi.y));
    return cv::Rect(c0, r0, c1 - c0 + 1, r1 - r0 + 1) & cv::Rect(0, 0, f_.px, f_.px);
}

void Display::draw(cv::Mat &img, const DisplayObject &p, const cv::Rect &clip) const
{
    const cv::Rect r = footprint(p) & clip;
    for (int row = r.y; row < r.y + r.height; ++row) {
        float *dst = img.ptr<float>(row);
        const double y = f_.y_of(row);
        for (int col = r.x; col < r.x + r.width; ++col) {
            const double z = sphere_profile_nm(p.radius_nm, std::hypot(f_.x_of(col) - p.x_nm, y - p.y_nm), tip_);
            if (z > dst[col]) dst[col] = static_cast<float>(z);
        }
    }
}

void Display::colourise_into(const cv::Rect &r)
{
    if (r.area() > 0) colourise(height_(r)).copyTo(colour_(r));
}

cv::Mat Display::colourise(const cv::Mat &h_nm) const
{
    cv::Mat u8, bgr;
    h_nm.convertTo(u8, CV_8U, 255.0 / z_top_);
    cv::cvtColor(u8, bgr, cv::COLOR_GRAY2BGR);
    cv::LUT(bgr, lut_, bgr);
    return bgr;
}

void Display::start(const cv::Mat &scan_nm, const std::vector<DisplayObject> &objects)
{
    double zmax;
    cv::minMaxLoc(scan_nm, nullptr, &zmax);
    z_top_ = std::max(1.0, zmax * 1.1);
    base_ = scan_nm.clone();
    for (const auto &p : objects) base_(footprint(p)).setTo(0.0f);
    drawn_.clear();
    for (const auto &p : objects) drawn_[p.id] = p;
    colour_ = cv::Mat(f_.px, f_.px, CV_8UC3);
    redraw(objects);
}

long Display::redraw(const std::vector<DisplayObject> &objects)
{
    height_ = base_.clone();
    const cv::Rect all(0, 0, f_.px, f_.px);
    for (const auto &p : objects) {
        draw(height_, p, all);
        drawn_[p.id] = p;
    }
    colourise_into(all);
    return static_cast<long>(all.area());
}

long Display::update(const std::vector<DisplayObject> &objects)
{
    std::vector<cv::Rect> dirty;
    for (const auto &p : objects) {
        auto it = drawn_.find(p.id);
        if (it != drawn_.end() && it->second.x_nm == p.x_nm && it->second.y_nm == p.y_nm && it->second.radius_nm == p.radius_nm)
            continue;
        cv::Rect r = footprint(p);
        if (it != drawn_.end()) {
            r |= footprint(it->second);
            if (trails_) trail_pts_.push_back(f_.to_px(it->second.x_nm, it->second.y_nm));
        }
        dirty.push_back(r);
        drawn_[p.id] = p;
    }
    long touched = 0;
    for (const cv::Rect &r : dirty) {
        base_(r).copyTo(height_(r));
        for (const auto &kv : drawn_)
            if ((footprint(kv.second) & r).area() > 0) draw(height_, kv.second, r);
        colourise_into(r);
        touched += r.area();
    }
    return touched;
}

void Display::paste_scan(const cv::Mat &scan_nm, const cv::Rect &where)
{
    const cv::Rect r = where & cv::Rect(0, 0, f_.px, f_.px);
    scan_nm(cv::Rect(r.x - where.x, r.y - where.y, r.width, r.height)).copyTo(height_(r));
    // The background under the objects there is what the local scan shows
    // with the modelled objects erased.
    height_(r).copyTo(base_(r));
    for (const auto &kv : drawn_) {
        const cv::Rect fp = footprint(kv.second) & r;
        if (fp.area() > 0) base_(fp).setTo(0.0f);
    }
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
    cv::putText(img, text, cv::Point(4, 12), cv::FONT_HERSHEY_PLAIN, 0.8, kWhite, 1, cv::LINE_AA);
    std::string flags;
    if (o.flags & fw_force_t::FLAG_CONTACT) flags += "PUSH ";
    if (o.flags & (fw_force_t::FLAG_SAT_SN | fw_force_t::FLAG_SAT_SL)) flags += "SATURATED ";
    if (o.flags & fw_force_t::FLAG_FX_UNOBSERVABLE) flags += "Fx-FALLBACK ";
    if (o.flags & fw_force_t::FLAG_SQUEEZE) flags += "SQUEEZE ";
    if (!flags.empty()) cv::putText(img, flags, cv::Point(4, 24), cv::FONT_HERSHEY_PLAIN, 0.8, kYellow, 1, cv::LINE_AA);
    // Colour bar (height, nm) at the right edge.
    const int bw = std::max(4, N / 40), bx = N - bw - 30, by0 = 30, by1 = N - 30;
    if (by1 - by0 > 20) {
        for (int y = by0; y <= by1; ++y) {
            const int v = cvRound(255.0 * (by1 - y) / (by1 - by0));
            const cv::Vec3b c = lut_.at<cv::Vec3b>(0, v);
            cv::line(img, cv::Point(bx, y), cv::Point(bx + bw, y), cv::Scalar(c[0], c[1], c[2]));
        }
        cv::rectangle(img, cv::Point(bx - 1, by0 - 1), cv::Point(bx + bw + 1, by1 + 1), kWhite);
        std::snprintf(text, sizeof text, "%.0f", z_top_);
        cv::putText(img, text, cv::Point(bx + bw + 3, by0 + 4), cv::FONT_HERSHEY_PLAIN, 0.7, kWhite, 1, cv::LINE_AA);
        cv::putText(img, "0", cv::Point(bx + bw + 3, by1 + 4), cv::FONT_HERSHEY_PLAIN, 0.7, kWhite, 1, cv::LINE_AA);
        cv::putText(img, "nm", cv::Point(bx - 2, by0 - 6), cv::FONT_HERSHEY_PLAIN, 0.7, kWhite, 1, cv::LINE_AA);
    }
    // Scale bar: the largest round length up to a quarter of the field.
    const double nice[] = {10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000};
    double len = nice[0];
    for (double v : nice)
        if (v <= f_.size_nm / 4) len = v;
    const int lpx = cvRound(len / f_.pitch());
    cv::line(img, cv::Point(8, N - 10), cv::Point(8 + lpx, N - 10), kWhite, 2);
    if (len >= 1000) std::snprintf(text, sizeof text, "%g um", len / 1000);
    else std::snprintf(text, sizeof text, "%g nm", len);
    cv::putText(img, text, cv::Point(8, N - 15), cv::FONT_HERSHEY_PLAIN, 0.7, kWhite, 1, cv::LINE_AA);
    return img;
}

bool write_gsf(const std::string &path, const cv::Mat &h_nm, const Field &f, const std::string &title, std::string *err)
{
    // Gwyddion Simple Field 1.0: a text header of "Key = value" lines, NUL
    // padding to a multiple of 4 bytes (at least one NUL), then XRes * YRes
    // little-endian float32 values, row by row from the top.
    char hdr[512];
    std::snprintf(hdr, sizeof hdr,
                  "Gwyddion Simple Field 1.0\nXRes = %d\nYRes = %d\nXReal = %.9g\nYReal = %.9g\nXOffset = %.9g\n"
                  "YOffset = %.9g\nXYUnits = m\nZUnits = m\nTitle = %s\n",
                  h_nm.cols, h_nm.rows, f.size_nm * 1e-9, f.size_nm * 1e-9, f.x0_nm * 1e-9, f.y0_nm * 1e-9, title.c_str());
    std::string header(hdr);
    const std::size_t pad = 4 - header.size() % 4;
    header.append(pad, '\0');
    std::ofstream out(path, std::ios::binary);
    if (!out) {
        if (err) *err = "cannot open " + path + " for writing";
        return false;
    }
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    static_assert(sizeof(float) == 4, "GSF stores float32");
    for (int r = 0; r < h_nm.rows; ++r)
        for (int c = 0; c < h_nm.cols; ++c) {
            const float v = static_cast<float>(h_nm.at<float>(r, c) * 1e-9);
            unsigned char b[4];
            std::memcpy(b, &v, 4);   // x86-64 and Cortex hosts are little-endian; GSF is little-endian
            out.write(reinterpret_cast<const char *>(b), 4);
        }
    if (!out) {
        if (err) *err = "write failed on " + path;
        return false;
    }
    return true;
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
