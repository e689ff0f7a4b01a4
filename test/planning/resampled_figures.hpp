#pragma once
/// \file
/// A trajectory's speed, acceleration and clearance measured independently of the planner's own
/// acceptance check (TrajectoryOptimizer::Measure): positions only (Trajectory::Position) sampled
/// densely and differenced, and the distance computed from the true cylinder geometry (not from a
/// distance field). Tests compare these with the planner's figures and with the limits.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "quadtune/physics/obstacles.hpp"
#include "quadtune/planning/trajectory.hpp"

namespace quadtune::planning::testing {

struct ResampledFigures {
  double max_speed = 0.0;         ///< max |Δp / Δt| (central differences, m/s)
  double max_acceleration = 0.0;  ///< max |Δ²p / Δt²| (m/s²)
  double min_clearance =
      std::numeric_limits<double>::infinity();  ///< to the cylinders' surface (m)
};

/// Distance from `p` to the nearest cylinder's surface (negative inside), from the geometry:
/// horizontal distance to the axis minus the radius, for heights within the cylinder; above or
/// below it, the distance to the nearest point of the solid.
inline double TrueClearance(const std::vector<physics::CylinderObstacle>& cylinders,
                            const Eigen::Vector3d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& c : cylinders) {
    const double radial = std::hypot(p.x() - c.center_W.x(), p.y() - c.center_W.y()) - c.radius;
    const double below = c.z_min - p.z();
    const double above = p.z() - c.z_max;
    const double vertical = std::max(below, above);
    double d = 0.0;
    if (vertical <= 0.0) {
      d = radial > 0.0 ? radial : std::max(radial, vertical);
    } else {
      d = radial > 0.0 ? std::hypot(radial, vertical) : vertical;
    }
    best = std::min(best, d);
  }
  return best;
}

/// Samples `trajectory` every `h` seconds (positions only) and differences them.
inline ResampledFigures Resample(const Trajectory& trajectory,
                                 const std::vector<physics::CylinderObstacle>& cylinders,
                                 double h = 1e-3) {
  ResampledFigures f;
  const double duration = trajectory.Duration();
  const auto p = [&](double t) { return trajectory.Position(std::clamp(t, 0.0, duration)); };
  for (double t = h; t < duration - h; t += h) {
    const Eigen::Vector3d before = p(t - h);
    const Eigen::Vector3d here = p(t);
    const Eigen::Vector3d after = p(t + h);
    f.max_speed = std::max(f.max_speed, (after - before).norm() / (2.0 * h));
    f.max_acceleration =
        std::max(f.max_acceleration, (after - 2.0 * here + before).norm() / (h * h));
    f.min_clearance = std::min(f.min_clearance, TrueClearance(cylinders, here));
  }
  f.min_clearance = std::min(
      {f.min_clearance, TrueClearance(cylinders, p(0.0)), TrueClearance(cylinders, p(duration))});
  return f;
}

}  // namespace quadtune::planning::testing
