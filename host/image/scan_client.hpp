// A raster scan asked of the simulator (AFM_SCAN_REQ) and received line by
// line (AFM_SCAN_LINE), lines lost on the bus asked again. The renderer
// (its full and local scans) and the planner's operator (its local scans)
// use it; each requester keeps to its own req_id range. Given the card's
// scanner model (set_dewarp: scan_dewarp.hpp), a scan is aimed by it (the
// rectangle commanded is the one the card's inverse model puts on the
// region asked, unless the requester asks for the region as it is) and,
// once whole, de-warped by it: heights() places each pixel where the
// card's model says the tip was, on the region asked; raw_heights() keeps
// the scan as it came.
#pragma once

#include <lcm/lcm-cpp.hpp>
#include <opencv2/core.hpp>

#include <chrono>
#include <vector>

#include "afm/scan_line_t.hpp"

namespace afm {

// The req_ids of the local scans a person asks for on the page
// (operator.mode browser): the operator asks for them (kPageScanReqBase +
// its count), at the display's pitch and on its pixels, and the renderer
// pastes each, once whole, into the display's background.
constexpr int kPageScanReqBase = 20000;

// A scan's rectangle: frame A, nm; nx pixels per line, ny lines.
struct ScanRegion {
    double x0_nm = 0, y0_nm = 0;        // lower-left corner
    double width_nm = 0, height_nm = 0;
    int nx = 0, ny = 0;
};

class ScanDewarp;

// What the de-warp of the last whole scan did.
struct DewarpNote {
    bool dewarped = false;     // the card's model placed the pixels
    double shift_nm = 0;       // the largest move of a pixel along either axis
    double aim_nm = 0;         // the largest move of the commanded rectangle's edges from the region asked (aimed by the card's model)
    int64_t model_utime = 0;   // the block end whose state the card's model was in, simulated us
    int64_t scan_utime = 0;    // the block end after which the simulator took the scan's last line
};

class ScanClient {
public:
    explicit ScanClient(lcm::LCM &lc) : lc_(lc) {}

    // The card's scanner model that de-warps each whole scan (null: none);
    // it must outlive the client.
    void set_dewarp(const ScanDewarp *d) { dewarp_ = d; }

    // Asks for the whole scan of r (a new one: any scan in progress is
    // dropped), at once or when the simulator waits after block at_seq
    // (scan_req_t); aim: commanded where the card's model puts it on r
    // (false: r commanded as it is, e.g. a scan whose lines a reader places
    // by their own coordinates).
    void start(int req_id, const ScanRegion &r, int64_t at_seq = -1, bool aim = true);
    // A line from the bus: stored if it is one of ours; true when it was
    // the last one missing.
    bool on_line(const scan_line_t &m);
    // Asks again for the lines still missing, if retry_ms passed since the
    // last request and the last line received (a scan that takes longer
    // than retry_ms to serve is not asked for again while its lines come).
    void retry(int retry_ms = 500);

    bool busy() const { return left_ > 0; }
    int id() const { return id_; }
    const ScanRegion &region() const { return r_; }     // the region asked
    const ScanRegion &commanded() const { return cmd_; }   // the rectangle commanded (the region asked, unless aimed)
    const cv::Mat &heights() const { return h_; }   // nm, CV_32F, ny x nx, row 0 at the top; de-warped once whole
    // Another image of the same scan (its lateral signal, as it came)
    // de-warped as heights() was: on the region asked.
    cv::Mat placed(const cv::Mat &raw) const;
    const cv::Mat &raw_heights() const { return raw_; }   // the whole scan as it came (empty before)
    const DewarpNote &dewarp_note() const { return note_; }

private:
    void request(int first, int n);
    void finish();

    lcm::LCM &lc_;
    const ScanDewarp *dewarp_ = nullptr;
    int id_ = 0;
    int64_t at_seq_ = -1;
    ScanRegion r_, cmd_;
    cv::Mat h_, raw_;
    DewarpNote note_;
    int64_t line_utime_ = 0;
    std::vector<bool> got_;
    int left_ = 0;
    std::chrono::steady_clock::time_point asked_;
};

}  // namespace afm
