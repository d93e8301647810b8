#include "scan_client.hpp"

#include <algorithm>
#include <cmath>

#include "afm/scan_req_t.hpp"
#include "afm_channels.h"
#include "bus.hpp"
#include "scan_dewarp.hpp"

namespace afm {

void ScanClient::start(int req_id, const ScanRegion &r, int64_t at_seq, bool aim)
{
    id_ = req_id;
    at_seq_ = at_seq;
    r_ = r;
    cmd_ = aim && dewarp_ && dewarp_->active() ? dewarp_->aim(r) : r;
    h_ = cv::Mat::zeros(r.ny, r.nx, CV_32F);
    raw_.release();
    note_ = DewarpNote{};
    const double x1 = r.x0_nm + r.width_nm, y1 = r.y0_nm + r.height_nm;
    note_.aim_nm = std::max({std::fabs(cmd_.x0_nm - r.x0_nm), std::fabs(cmd_.y0_nm - r.y0_nm),
                             std::fabs(cmd_.x0_nm + cmd_.width_nm - x1), std::fabs(cmd_.y0_nm + cmd_.height_nm - y1)});
    line_utime_ = 0;
    got_.assign(static_cast<std::size_t>(r.ny), false);
    left_ = r.ny;
    request(0, r.ny);
}

void ScanClient::request(int first, int n)
{
    scan_req_t q{};
    q.utime = wall_utime();
    q.req_id = id_;
    q.x0_nm = cmd_.x0_nm;
    q.y0_nm = cmd_.y0_nm;
    q.width_nm = cmd_.width_nm;
    q.height_nm = cmd_.height_nm;
    q.nx = r_.nx;
    q.ny = r_.ny;
    q.first_line = first;
    q.n_lines = n;
    q.at_seq = at_seq_;
    afm::publish(lc_, AFM_CH_AFM_SCAN_REQ, q);
    asked_ = std::chrono::steady_clock::now();
}

bool ScanClient::on_line(const scan_line_t &m)
{
    if (left_ == 0 || m.req_id != id_ || m.n != r_.nx || m.line < 0 || m.line >= r_.ny || got_[static_cast<std::size_t>(m.line)])
        return false;
    float *row = h_.ptr<float>(r_.ny - 1 - m.line);
    for (int i = 0; i < r_.nx; ++i) row[i] = static_cast<float>(m.height_nm[static_cast<std::size_t>(i)]);
    got_[static_cast<std::size_t>(m.line)] = true;
    line_utime_ = std::max(line_utime_, m.utime);
    asked_ = std::chrono::steady_clock::now();   // the scan is coming: a retry waits for it to stop
    if (--left_ > 0) return false;
    finish();
    return true;
}

void ScanClient::finish()
{
    raw_ = h_.clone();
    note_.scan_utime = line_utime_;
    if (!dewarp_ || !dewarp_->active()) return;
    h_ = dewarp_->apply(raw_, cmd_, r_, &note_.shift_nm, note_.scan_utime);
    note_.dewarped = true;
    note_.model_utime = dewarp_->state_utime();
}

cv::Mat ScanClient::placed(const cv::Mat &raw) const
{
    return dewarp_ && dewarp_->active() ? dewarp_->apply(raw, cmd_, r_, nullptr, note_.scan_utime) : raw.clone();
}

void ScanClient::retry(int retry_ms)
{
    if (left_ == 0 || std::chrono::steady_clock::now() - asked_ < std::chrono::milliseconds(retry_ms)) return;
    for (int j = 0; j < r_.ny;) {
        if (got_[static_cast<std::size_t>(j)]) {
            ++j;
            continue;
        }
        int k = j;
        while (k < r_.ny && !got_[static_cast<std::size_t>(k)]) ++k;
        request(j, k - j);
        j = k;
    }
}

}  // namespace afm
