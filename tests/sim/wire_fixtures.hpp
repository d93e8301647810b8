// The simulated nanowires' tests' shared fixtures (tests/sim/test_rods.cpp,
// test_rod_solver.cpp, test_flexible_wires.cpp, test_wires.cpp): physics.md
// section 6's closed forms for a rod, the one-wire scene, the rod's lumped
// solver and a push through the whole world.
//
// Closed forms (rod of length L from end A, friction density f, pushed
// perpendicular to its axis at distance l from A):
//   static point  s = l + sqrt((l - L/2)^2 + L^2/4)  for l < L/2   (eq. 20)
//                 s = l - sqrt((l - L/2)^2 + L^2/4)  for l > L/2
//   least push    F = f |L - 2 s| = f (2 sqrt((l - L/2)^2 + L^2/4) - |L - 2 l|)
//   F(0) = (sqrt2 - 1) f L = 0.414 f L; F(L/2) = f L, pure translation.
// (physics.md's printed eq. 22, f (2 sqrt(...) - L), drops the |L - 2 l| term:
// it is right only at the ends; at l = L/4 it gives 0.118 f L, against the
// 0.618 f L that both balances and the net friction |L - 2 s| f give.)
#pragma once

#include <unity.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "../scene_text.hpp"
#include "wire.hpp"
#include "world.hpp"

inline double s_closed(double l, double L)
{
    const double r = std::sqrt((l - L / 2) * (l - L / 2) + L * L / 4);
    return l < L / 2 ? l + r : l - r;
}

inline double k_closed(double l, double L)   // F_min / (f L)
{
    return (2 * std::sqrt((l - L / 2) * (l - L / 2) + L * L / 4) - std::fabs(L - 2 * l)) / L;
}

constexpr const char *kWireScene = R"(name: wire-unit
seed: 5
duration_s: 1
sample_rate_hz: 20000
block_hz: 1000
frame_rate_hz: 25
effects: [bending_offset, adhesion EXTRA]
sample:
  substrate: glass
  field_nm: 8000
  tip_substrate: {mu: 0.1, adhesion_nN: 1.0}
  wire: {friction_nN_per_um: FRICTION, segments: SEGMENTS, friction_points: 64, relax_sweeps: SWEEPS, solver: SOLVER}
objects:
  wires:
    - {id: 4, x0_nm: -HALF, y0_nm: 0, x1_nm: HALF, y1_nm: 0, diameter_nm: 100}
probe: {tip_half_angle_deg: GAMMA}
operator:
  load_nN: LOAD
  path_nm: [[0, -300]]
)";

inline afm::Scene wire_scene(double L, const std::string &extra = "", double friction = 20, int segments = 32, int sweeps = 8,
                      double load_nN = 5, double gamma_deg = 20, const std::string &solver = "closed_form")
{
    std::string t = with(kWireScene, "SWEEPS", std::to_string(sweeps));
    t = with(t, "SOLVER", solver);
    t = with(t, "LOAD", std::to_string(load_nN));
    t = with(t, "GAMMA", std::to_string(gamma_deg));
    t = with(t, "EXTRA", extra);
    t = with(t, "FRICTION", std::to_string(friction));
    t = with(t, "SEGMENTS", std::to_string(segments));
    t = with(t, "-HALF", std::to_string(-L / 2));
    t = with(t, "HALF", std::to_string(L / 2));
    return scene_from_text(t);
}

// Least-dissipation twist for a perpendicular push at l from end A, K points.
inline afm::sim::RodTwist solve(double l, double L, double f, int K)
{
    std::vector<double> u(K);
    for (int k = 0; k < K; ++k) u[k] = -L / 2 + (k + 0.5) * L / K;
    return afm::sim::rod_push_twist(u, f * L / K, l - L / 2, Eigen::Vector2d(0, 1), afm::sim::RodTwist{}, 1e-14, 5000);
}

// Pushes a 1 um rod lying along x with the tip moving along +y at x = l - L/2:
// returns the wire's rotation centre (from its motion) and the force the wire
// takes (lateral force on the tip less the tip's own friction) while sliding.
struct PushResult { double s_nm, force_nN, dpsi; };

inline PushResult push_world(double l, double L, const std::string &extra = "", int segments = 32, int sweeps = 8, double load_nN = 5,
                      const std::string &solver = "closed_form")
{
    const afm::Scene s = wire_scene(L, extra, 20, segments, sweeps, load_nN, 20, solver);
    afm::sim::World w(s);
    const double cn_off = w.lever().normal_offset(s.op.load_nN).x();
    const double x = l - L / 2;
    // Quasi-static push: the solver converges every sample to its residual
    // (physics.md 5.1) and the piezo advances 0.05 nm per sample (1 um/s, an
    // operator's pace).
    double y = -70;
    w.command(Eigen::Vector2d(x - cn_off, y), s.op.load_nN, true);
    for (int i = 0; i < 1000; ++i) w.step();
    auto axis_y = [&](double xq) {   // the axis's y at x = xq (small rotations)
        const auto &n = w.wires()[0]->nodes();
        const Eigen::Vector2d a = n.front(), b = n.back();
        return a.y() + (b.y() - a.y()) * (xq - a.x()) / (b.x() - a.x());
    };
    auto angle = [&]() {
        const auto &n = w.wires()[0]->nodes();
        return std::atan2(n.back().y() - n.front().y(), n.back().x() - n.front().x());
    };
    // Contact at y = -(r_t + d/2) = -60; the lever twists by about 12 nm
    // before the wire slides; samples 700 to 1300 see 30 nm of steady sliding.
    double fsum = 0;
    int nf = 0;
    double y0 = 0, psi0 = 0;
    for (int i = 0; i <= 1300; ++i) {
        y += 0.05;
        w.command(Eigen::Vector2d(x - cn_off, y), s.op.load_nN, true);
        w.step();
        if (i == 700) {
            y0 = axis_y(-L / 2);
            psi0 = angle();
        }
        if (i > 700) {
            fsum += w.tip_force().y();
            ++nf;
        }
    }
    const double friction = s.tip_substrate.mu * (s.op.load_nN + s.tip_substrate.adhesion_nN);
    const double dpsi = angle() - psi0;
    const double dyA = axis_y(-L / 2) - y0;
    // Normal displacement at distance s from end A: dyA + dpsi s; zero at s = -dyA / dpsi.
    return PushResult{std::fabs(dpsi) > 1e-12 ? -dyA / dpsi : INFINITY, -fsum / nf - friction, dpsi};
}

// kWireScene with its placeholders filled (a 1.3 um rod, gamma 20 deg).
inline std::string filled(std::string t)
{
    for (const auto &[k, v] : std::vector<std::pair<std::string, std::string>>{
             {"SWEEPS", "8"}, {"SOLVER", "closed_form"}, {"LOAD", "5"}, {"GAMMA", "20"}, {"EXTRA", ""}, {"FRICTION", "20"},
             {"SEGMENTS", "32"}, {"-HALF", "-650"}, {"HALF", "650"}})
        t = with(t, k, v);
    return t;
}
