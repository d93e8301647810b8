// The scanner's piezo: hysteresis and creep (piezo.hpp).
#include "piezo.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

#include "scan_raster.hpp"

namespace afm::sim {

PlayHysteresis::PlayHysteresis(double width, double span_nm, double x0_nm) : x0_(x0_nm), y_(x0_nm)
{
    // w = a / (4 - 2 a) (header), so a = 4 w / (1 + 2 w); g = 1 / (1 - a / 2)
    a_ = 4.0 * width / (1.0 + 2.0 * width);
    g_ = 1.0 / (1.0 - a_ / 2.0);
    for (int i = 0; i < kPlays; ++i) {
        r_[i] = (i + 0.5) / kPlays * span_nm / 2.0;
        play_[i] = x0_nm;
    }
}

double PlayHysteresis::step(double x_nm)
{
    double sum = 0;
    for (int i = 0; i < kPlays; ++i) {
        play_[i] = std::max(x_nm - r_[i], std::min(x_nm + r_[i], play_[i]));
        sum += play_[i] - x0_;
    }
    y_ = x0_ + g_ * ((1.0 - a_) * (x_nm - x0_) + a_ / kPlays * sum);
    return y_;
}

LogCreep::LogCreep(double gamma, double t0_s, double span_s, double dt_s, double y0_nm) : gamma_(gamma), y0_(y0_nm)
{
    // Relaxers log-spaced over [t0, T], one more than its decades (at least 2).
    const double T = std::max(span_s, 10.0 * t0_s);
    const double decades = std::log10(T / t0_s);
    const int n = std::max(2, static_cast<int>(std::ceil(decades - 1e-9)) + 1);
    for (int k = 0; k < n; ++k) tau_.push_back(t0_s * std::pow(T / t0_s, static_cast<double>(k) / (n - 1)));
    // Least squares: sum_k c_k (1 - exp(-t / tau_k)) - b = log10(t / t0) at
    // kFit times log-spaced over [t0, T].
    constexpr int kFit = 64;
    Eigen::MatrixXd A(kFit, n + 1);
    Eigen::VectorXd rhs(kFit);
    for (int j = 0; j < kFit; ++j) {
        const double t = t0_s * std::pow(T / t0_s, static_cast<double>(j) / (kFit - 1));
        for (int k = 0; k < n; ++k) A(j, k) = 1.0 - std::exp(-t / tau_[k]);
        A(j, n) = -1.0;
        rhs(j) = std::log10(t / t0_s);
    }
    const Eigen::VectorXd x = A.colPivHouseholderQr().solve(rhs);
    fit_error_ = (A * x - rhs).cwiseAbs().maxCoeff();
    for (int k = 0; k < n; ++k) {
        c_.push_back(x(k));
        keep_.push_back(std::exp(-dt_s / tau_[k]));
        s_.push_back(y0_nm);
    }
    b_ = x(n);
}

double LogCreep::step(double y_nm)
{
    double sum = 0;
    for (std::size_t k = 0; k < s_.size(); ++k) {
        s_[k] = y_nm + keep_[k] * (s_[k] - y_nm);
        sum += c_[k] * (s_[k] - y0_);
    }
    return y_nm + gamma_ * (sum - b_ * (y_nm - y0_));
}

std::vector<double> LogCreep::decay(double dt_s) const
{
    std::vector<double> keep;
    for (double tau : tau_) keep.push_back(std::exp(-dt_s / tau));
    return keep;
}

double LogCreep::output(const std::vector<double> &s, double y_nm) const
{
    double sum = 0;
    for (std::size_t k = 0; k < s.size(); ++k) sum += c_[k] * (s[k] - y0_);
    return y_nm + gamma_ * (sum - b_ * (y_nm - y0_));
}

namespace {

// s held at input v over a step whose decay is keep (LogCreep::step's update).
void hold(std::vector<double> &s, const std::vector<double> &keep, double v)
{
    for (std::size_t k = 0; k < s.size(); ++k) s[k] = v + keep[k] * (s[k] - v);
}

// The fast axis along line j (piezo.hpp): every line's inputs are the same
// trace (trace[i]) and retrace; from the relaxers' present state, j lines'
// affine maps in closed form, then the trace, each pixel's output.
void creep_fast_axis(const LogCreep &c, const std::vector<double> &trace, const std::vector<double> &retrace, int j, double pixel_s,
                     double *out)
{
    const std::vector<double> keep = c.decay(pixel_s), line_keep = c.decay(pixel_s * (trace.size() + retrace.size()));
    std::vector<double> s = c.relaxers(), b(s.size(), 0.0);
    for (double v : trace) hold(b, keep, v);   // one line from 0: B
    for (double v : retrace) hold(b, keep, v);
    for (std::size_t k = 0; k < s.size(); ++k) {
        const double a = line_keep[k], aj = std::pow(a, j);
        s[k] = aj * s[k] + (a < 1 ? b[k] * (1 - aj) / (1 - a) : b[k] * j);
    }
    for (std::size_t i = 0; i < trace.size(); ++i) {
        hold(s, keep, trace[i]);
        out[i] = c.output(s, trace[i]);
    }
}

// The slow axis along line j: line i < j held at lines[i] for a line's
// time, then this line's input held pixel by pixel.
void creep_slow_axis(const LogCreep &c, const std::vector<double> &lines, int n, double pixel_s, double *out)
{
    const std::vector<double> keep = c.decay(pixel_s), line_keep = c.decay(2 * n * pixel_s);
    std::vector<double> s = c.relaxers();
    for (std::size_t i = 0; i + 1 < lines.size(); ++i) hold(s, line_keep, lines[i]);
    for (int i = 0; i < n; ++i) {
        hold(s, keep, lines.back());
        out[i] = c.output(s, lines.back());
    }
}

}  // namespace

void PiezoXY::raster_line(const RasterLine &l, double *x_nm, double *y_nm) const
{
    // The slow axis's input at each line up to this one; the fast axis's
    // along the trace and the retrace (through copies of the hysteresis).
    const int j = l.dy_nm != 0 ? std::max(0, static_cast<int>(std::lround((l.y_nm - l.y_first_nm) / l.dy_nm))) : 0;
    std::optional<PlayHysteresis> ey = hy, ex = hx;
    std::vector<double> lines, trace(static_cast<std::size_t>(l.n)), retrace(static_cast<std::size_t>(l.n));
    for (int i = 0; i < j; ++i) lines.push_back(ey ? ey->step(l.y_first_nm + i * l.dy_nm) : l.y_first_nm + i * l.dy_nm);
    if (ey && j == 0) ey->step(l.y_first_nm);
    lines.push_back(ey ? ey->step(l.y_nm) : l.y_nm);
    if (ex) {
        ex->step(l.x0_nm + (l.n - 1) * l.dx_nm);
        ex->step(l.x0_nm);
    }
    for (int i = 0; i < l.n; ++i) trace[static_cast<std::size_t>(i)] = ex ? ex->step(l.x0_nm + i * l.dx_nm) : l.x0_nm + i * l.dx_nm;
    if (!cx) {
        std::copy(trace.begin(), trace.end(), x_nm);
        std::fill(y_nm, y_nm + l.n, lines.back());
        return;
    }
    for (int i = 0; i < l.n; ++i) {
        const double x = l.x0_nm + (l.n - 1 - i) * l.dx_nm;
        retrace[static_cast<std::size_t>(i)] = ex ? ex->step(x) : x;
    }
    const double pixel_s = scan_raster(l.dx_nm, l.n).pixel_s;
    creep_fast_axis(*cx, trace, retrace, j, pixel_s, x_nm);
    creep_slow_axis(*cy, lines, l.n, pixel_s, y_nm);
}

Eigen::Vector2d PiezoXY::step(const Eigen::Vector2d &drive_nm)
{
    Eigen::Vector2d p = drive_nm;
    if (hx) p = Eigen::Vector2d(hx->step(p.x()), hy->step(p.y()));
    if (cx) p = Eigen::Vector2d(cx->step(p.x()), cy->step(p.y()));
    return p;
}

std::unique_ptr<PiezoXY> make_piezo(const Scene &s, const Eigen::Vector2d &start_nm)
{
    const bool hysteresis = s.has_effect("piezo_hysteresis"), creep = s.has_effect("piezo_creep");
    if (!hysteresis && !creep) return nullptr;
    auto p = std::make_unique<PiezoXY>();
    const InstrumentSpec &in = s.instrument;
    if (hysteresis) {
        p->hx.emplace(in.hysteresis_width_pct / 100.0, in.hysteresis_span_nm, start_nm.x());
        p->hy.emplace(in.hysteresis_width_pct / 100.0, in.hysteresis_span_nm, start_nm.y());
    }
    if (creep) {
        const double dt = 1.0 / s.sample_rate_hz, gamma = in.creep_pct_per_decade / 100.0;
        const double span = s.duration_s + scan_seconds(s.field_nm / s.out.image_px, s.out.image_px, s.out.image_px);
        p->cx.emplace(gamma, in.creep_t0_s, span, dt, start_nm.x());
        p->cy.emplace(gamma, in.creep_t0_s, span, dt, start_nm.y());
    }
    return p;
}

}  // namespace afm::sim
