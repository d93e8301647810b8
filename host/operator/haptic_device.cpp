#include "haptic_device.hpp"

#include <algorithm>
#include <cmath>

namespace afm {

namespace {

constexpr int kSubsteps = 20;               // per block (backward Euler: the passive part is stable at any step)
constexpr double kControllerMax_Ns_per_m = 500.0;   // the controller's damping, at most
constexpr double kSlowest_m_per_s = 1e-4;   // below this the controller's damping is formed as at this speed

}  // namespace

HapticLoop::HapticLoop(const HapticSpec &device, const HandSpec &hand, double block_s, Vec2 start_m, Vec2 start_m_per_s)
    : dev_(device), hand_(hand), T_(block_s), x_(start_m), v_(start_m_per_s), aim_(start_m)
{
}

double HapticLoop::load_nN() const
{
    const double reach = dev_.half_range_mm * 1e-3;
    return dev_.load_span_nN * std::clamp(-z_ / reach, 0.0, 1.0);
}

void HapticLoop::step(Vec2 aim, Vec2 f, double aim_z, double fz)
{
    const double m = hand_.mass_kg, K = hand_.stiffness_N_per_m, B = hand_.damping_Ns_per_m, b = dev_.damping_Ns_per_m;
    const double dt = T_ / kSubsteps;
    const double reach = dev_.half_range_mm * 1e-3;
    const bool has_z = dev_.load_span_nN > 0;
    if (!has_z) aim_z = fz = 0;
    const Vec2 va{(aim.x - aim_.x) / T_, (aim.y - aim_.y) / T_};
    const double vaz = (aim_z - aim_z_) / T_;
    // The passivity controller: when the device has given the stylus more
    // energy than it took, the damping that takes the excess back over this
    // block at the present speed.
    double alpha = 0;
    if (controller_on_ && observed_J_ < 0) {
        const double v2 = std::max(v_.x * v_.x + v_.y * v_.y + vz_ * vz_, kSlowest_m_per_s * kSlowest_m_per_s);
        alpha = std::min(kControllerMax_Ns_per_m, -observed_J_ / (T_ * v2));
        ++controller_blocks_;
    }
    bool edge = false;
    for (int i = 1; i <= kSubsteps; ++i) {
        const double w = static_cast<double>(i) / kSubsteps;
        const Vec2 a{aim_.x + (aim.x - aim_.x) * w, aim_.y + (aim.y - aim_.y) * w};
        // Backward Euler per axis: m (v' - v) = dt (K (a - x - dt v') + B (va - v') - (b + alpha) v' + f).
        auto axis = [&](double &x, double &v, double ai, double vai, double fi) {
            v = (m * v + dt * (K * (ai - x) + B * vai + fi)) / (m + dt * (B + b + alpha) + dt * dt * K);
            x += dt * v;
            if (x > reach || x < -reach) {   // the mechanism's stop
                x = std::clamp(x, -reach, reach);
                v = 0;
                edge = true;
            }
        };
        axis(x_.x, v_.x, a.x, va.x, f.x);
        axis(x_.y, v_.y, a.y, va.y, f.y);
        if (has_z) axis(z_, vz_, aim_z_ + (aim_z - aim_z_) * w, vaz, fz);
        const double v2 = v_.x * v_.x + v_.y * v_.y + vz_ * vz_;
        observed_J_ += ((b + alpha) * v2 - (f.x * v_.x + f.y * v_.y + fz * vz_)) * dt;
        controller_J_ += alpha * v2 * dt;
    }
    if (edge) ++edge_blocks_;
    aim_ = aim;
    aim_z_ = aim_z;
}

}  // namespace afm
