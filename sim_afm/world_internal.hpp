// What the world's units share (world.cpp, world_contact.cpp, effects.cpp,
// world_imaging.cpp, world_trenches.cpp, surfaces.cpp). Internal to the
// simulator's library.
#pragma once

#include <chrono>

#include <Eigen/Core>

namespace afm::sim {

namespace {   // one copy per unit

constexpr double kBoltzmann_nN_nm_per_K = 1.380649e-5;  // 1.380649e-23 J/K in nN nm / K

inline Eigen::Vector2d unit_or(const Eigen::Vector2d &v, const Eigen::Vector2d &fallback)
{
    const double n = v.norm();
    return n > 1e-12 ? Eigen::Vector2d(v / n) : fallback;
}

inline double seconds_since(std::chrono::steady_clock::time_point t0)
{
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

}  // namespace afm::sim
