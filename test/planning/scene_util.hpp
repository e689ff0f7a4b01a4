#pragma once
// Test scenes for the planning tests: local maps filled from analytic obstacles.

#include <cmath>
#include <numbers>
#include <vector>

#include "quadtune/physics/obstacles.hpp"
#include "quadtune/planning/local_map.hpp"

namespace quadtune::planning::testing {

/// Points on the lateral surfaces of `obstacles`' cylinders (spacing ≈ `step`, m), as a depth
/// sensor that looked at everything would see them.
inline std::vector<Eigen::Vector3d> SurfacePoints(const physics::ObstacleSet& obstacles,
                                                  double step = 0.05) {
  std::vector<Eigen::Vector3d> points;
  for (const auto& c : obstacles.cylinders) {
    const int around = std::max(8, static_cast<int>(2.0 * std::numbers::pi * c.radius / step));
    for (double z = c.z_min; z <= c.z_max; z += step) {
      for (int k = 0; k < around; ++k) {
        const double a = 2.0 * std::numbers::pi * k / around;
        points.emplace_back(c.center_W.x() + c.radius * std::cos(a),
                            c.center_W.y() + c.radius * std::sin(a), z);
      }
    }
  }
  return points;
}

/// A wall of points across x = x_wall, spanning |y| <= half_width and z in [0, height].
inline std::vector<Eigen::Vector3d> WallPoints(double x_wall, double half_width, double height,
                                               double step = 0.05) {
  std::vector<Eigen::Vector3d> points;
  for (double y = -half_width; y <= half_width; y += step) {
    for (double z = 0.0; z <= height; z += step) points.emplace_back(x_wall, y, z);
  }
  return points;
}

/// A row of cylinders across the corridor at x with gaps, for a quick forest.
inline physics::ObstacleSet SmallForest() {
  physics::ObstacleSet set;
  const double xs[] = {3.0, 4.5, 6.0};
  const double ys[][3] = {{-1.0, 0.4, 1.8}, {-1.8, -0.3, 1.2}, {-0.9, 0.6, 2.1}};
  for (int i = 0; i < 3; ++i) {
    for (double y : ys[i]) set.cylinders.push_back({{xs[i], y}, 0.25, 0.0, 3.0});
  }
  return set;
}

}  // namespace quadtune::planning::testing
