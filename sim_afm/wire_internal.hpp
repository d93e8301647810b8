// What the wire models' units share (wire.cpp, rod.cpp, flexible_wire.cpp):
// the line searches' constants and the polyline's closest segment.
// Internal to the simulator's library.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

namespace afm::sim::detail {

// Armijo's sufficient decrease (both line searches), as a fraction of the
// first-order decrease.
constexpr double kArmijo = 1e-4;
// Step halvings at most in either line search.
constexpr int kMaxHalvings = 30;

// The segment of the polyline xs (at least two points) closest to q, the
// first of equals, and its parameter t in [0, 1] (wire.cpp).
std::size_t closest_segment(const std::vector<Eigen::Vector2d> &xs, const Eigen::Vector2d &q, double &t);

}  // namespace afm::sim::detail
