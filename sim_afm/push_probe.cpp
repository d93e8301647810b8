// A push at constant speed, measured (push_probe.hpp).

#include "push_probe.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <vector>

#include "world.hpp"

namespace afm::sim {

namespace {

constexpr int kSettleSamples = 200;    // at the start, before the push
constexpr double kRestSeconds = 0.01;  // at the end, before the final position

bool object_touches(const World &w)
{
    if (!w.particles().empty()) return w.particles()[0].in_contact;
    return !w.wires().empty() && w.wires()[0]->in_contact;
}

double object_y(const World &w)
{
    if (!w.particles().empty()) return w.particle_position(0).y();
    const auto &x = w.wires()[0]->nodes();
    double y = 0;
    for (const auto &p : x) y += p.y();
    return w.to_frame_A(Eigen::Vector2d(0, y / static_cast<double>(x.size()))).y();
}

}  // namespace

PushRun push_at_speed(const Scene &s, double x_nm, double y0_nm, double y1_nm, double v_nm_per_s, int cap)
{
    World w(s);
    w.set_solver_cap(cap);
    const double load = s.op.load_nN;
    const double adh = s.has_effect("adhesion") ? s.tip_substrate.adhesion_nN : 0.0;
    const double tip_friction = s.tip_substrate.mu * (load + adh);
    const double x = x_nm - w.lever().normal_offset(load).x();
    w.command(Eigen::Vector2d(x, y0_nm), load, true);
    for (int i = 0; i < kSettleSamples; ++i) w.step();
    std::vector<double> force;
    const double dy = v_nm_per_s * w.dt();
    for (double y = y0_nm; y < y1_nm;) {
        y = std::min(y1_nm, y + dy);
        w.command(Eigen::Vector2d(x, y), load, true);
        w.step();
        if (object_touches(w)) force.push_back(-w.tip_force().y() - tip_friction);   // the sample's force on the tip opposes the push
    }
    const long rest = std::lround(kRestSeconds / w.dt());
    for (long i = 0; i < rest; ++i) w.step();
    PushRun r;
    r.contact_samples = static_cast<long>(force.size());
    const std::size_t half = force.size() / 2;
    if (force.size() > half)
        r.force_nN = std::accumulate(force.begin() + static_cast<long>(half), force.end(), 0.0) / static_cast<double>(force.size() - half);
    r.final_nm = object_y(w);
    const auto &st = w.solver();
    r.samples = st.samples;
    r.sweeps = st.sweeps;
    r.max_sweeps = st.max_sweeps;
    r.worst_force_nN = st.worst_force_nN;
    r.worst_gap_nm = st.worst_gap_nm;
    r.unconverged = st.unconverged;
    return r;
}

}  // namespace afm::sim
