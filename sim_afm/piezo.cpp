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

// The creep of one axis at line j's time (common/scan_raster.hpp): from the
// relaxers' present state, line i < j held at lines[i] for a line's time,
// then this line's input held a quarter line; the creep then, at it.
double creep_at_line(const LogCreep &c, const std::vector<double> &lines, double line_s)
{
    const std::vector<double> keep = c.decay(line_s), quarter = c.decay(0.25 * line_s);
    std::vector<double> s = c.relaxers();
    auto hold = [&](const std::vector<double> &k, double v) {
        for (std::size_t m = 0; m < s.size(); ++m) s[m] = v + k[m] * (s[m] - v);
    };
    for (std::size_t i = 0; i + 1 < lines.size(); ++i) hold(keep, lines[i]);
    hold(quarter, lines.back());
    return c.output(s, lines.back()) - lines.back();
}

}  // namespace

void PiezoXY::raster_line(const RasterLine &l, double *x_nm, double *y_nm) const
{
    // The slow axis's input at each line up to this one, the fast axis's
    // along the trace (through copies of the hysteresis: to the line's end
    // and back, then along the line); the fast axis's creep input is the
    // line's start, held (common/scan_raster.hpp).
    const int j = l.dy_nm != 0 ? std::max(0, static_cast<int>(std::lround((l.y_nm - l.y_first_nm) / l.dy_nm))) : 0;
    std::optional<PlayHysteresis> ey = hy, ex = hx;
    std::vector<double> lines;
    for (int i = 0; i < j; ++i) lines.push_back(ey ? ey->step(l.y_first_nm + i * l.dy_nm) : l.y_first_nm + i * l.dy_nm);
    if (ey && j == 0) ey->step(l.y_first_nm);
    lines.push_back(ey ? ey->step(l.y_nm) : l.y_nm);
    if (ex) {
        ex->step(l.x0_nm + (l.n - 1) * l.dx_nm);
        ex->step(l.x0_nm);
    }
    for (int i = 0; i < l.n; ++i) x_nm[i] = ex ? ex->step(l.x0_nm + i * l.dx_nm) : l.x0_nm + i * l.dx_nm;
    double ox = 0, oy = 0;
    if (cx) {
        const double line_s = scan_raster(l.dx_nm, l.n).line_s;
        ox = creep_at_line(*cx, std::vector<double>(lines.size(), x_nm[0]), line_s);
        oy = creep_at_line(*cy, lines, line_s);
    }
    for (int i = 0; i < l.n; ++i) x_nm[i] += ox;
    std::fill(y_nm, y_nm + l.n, lines.back() + oy);
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
