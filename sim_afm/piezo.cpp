// The scanner's piezo: hysteresis and creep (piezo.hpp).
#include "piezo.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>

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
        p->cx.emplace(gamma, in.creep_t0_s, s.duration_s, dt, start_nm.x());
        p->cy.emplace(gamma, in.creep_t0_s, s.duration_s, dt, start_nm.y());
    }
    return p;
}

}  // namespace afm::sim
