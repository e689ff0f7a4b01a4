#pragma once
/// \file
/// Test and benchmark scenes for the mapping front end: seeded cylinder forests, an analytic
/// depth "scan" (pinhole rays against cylinders and the ground, world-frame hit points), and
/// dense surface samples. Test-only helpers; the real depth sensor lives in physics.

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "quadtune/common/random.hpp"
#include "quadtune/physics/obstacles.hpp"

namespace quadtune::planning::test {

/// Cylinders on a jittered square grid of `spacing` (m) over [x0, x1] × [y0, y1], radii in
/// [0.15, 0.3] m, 3 m tall; cells whose centre lies within `keep_clear` of a point in
/// `clear_points` stay empty (start/goal).
inline physics::ObstacleSet Forest(double spacing, double x0, double x1, double y0, double y1,
                                   std::uint64_t seed,
                                   const std::vector<Eigen::Vector2d>& clear_points = {},
                                   double keep_clear = 0.8) {
  physics::ObstacleSet set;
  Rng rng(seed);
  for (double x = x0; x <= x1 + 1e-9; x += spacing) {
    for (double y = y0; y <= y1 + 1e-9; y += spacing) {
      physics::CylinderObstacle c;
      c.center_W = Eigen::Vector2d(x + Uniform(rng, -0.25, 0.25) * spacing,
                                   y + Uniform(rng, -0.25, 0.25) * spacing);
      c.radius = Uniform(rng, 0.15, 0.3);
      c.z_min = 0.0;
      c.z_max = 3.0;
      bool ok = true;
      for (const auto& p : clear_points) ok = ok && (c.center_W - p).norm() > keep_clear + c.radius;
      if (ok) set.cylinders.push_back(c);
    }
  }
  return set;
}

/// First intersection (ray parameter, m) of origin + t·dir (|dir| = 1) with the scene's
/// cylinders (side and top) and the ground; +inf when none.
inline double CastRay(const physics::ObstacleSet& set, const Eigen::Vector3d& o,
                      const Eigen::Vector3d& dir) {
  double best = std::numeric_limits<double>::infinity();
  if (set.ground && dir.z() < 0.0) best = -o.z() / dir.z();
  for (const auto& c : set.cylinders) {
    const Eigen::Vector2d o2 = o.head<2>() - c.center_W;
    const Eigen::Vector2d d2 = dir.head<2>();
    const double a = d2.squaredNorm();
    const double b = 2.0 * o2.dot(d2);
    const double cc = o2.squaredNorm() - c.radius * c.radius;
    if (a > 1e-12) {
      const double disc = b * b - 4.0 * a * cc;
      if (disc >= 0.0) {
        const double t = (-b - std::sqrt(disc)) / (2.0 * a);
        const double z = o.z() + t * dir.z();
        if (t > 0.0 && t < best && z >= c.z_min && z <= c.z_max) best = t;
      }
    }
    if (std::abs(dir.z()) > 1e-12) {
      const double t = (c.z_max - o.z()) / dir.z();
      if (t > 0.0 && t < best && (o2 + t * d2).norm() <= c.radius) best = t;
    }
  }
  return best;
}

/// A pinhole depth scan of width × height rays (fov in rad) looking along yaw (rad, from +x)
/// from origin_W; returns the world-frame hit points within max_range.
inline std::vector<Eigen::Vector3d> Scan(const physics::ObstacleSet& set,
                                         const Eigen::Vector3d& origin_W, double yaw, int width,
                                         int height, double max_range = 5.0,
                                         double hfov = std::numbers::pi / 2.0,
                                         double vfov = std::numbers::pi / 3.0) {
  std::vector<Eigen::Vector3d> hits;
  hits.reserve(static_cast<std::size_t>(width) * height);
  const double fx = std::tan(hfov / 2.0);
  const double fz = std::tan(vfov / 2.0);
  const Eigen::Vector3d fwd(std::cos(yaw), std::sin(yaw), 0.0);
  const Eigen::Vector3d left(-std::sin(yaw), std::cos(yaw), 0.0);
  const Eigen::Vector3d up(0.0, 0.0, 1.0);
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const double u = (2.0 * (c + 0.5) / width - 1.0) * fx;
      const double v = (2.0 * (r + 0.5) / height - 1.0) * fz;
      const Eigen::Vector3d dir = (fwd - u * left + v * up).normalized();
      const double t = CastRay(set, origin_W, dir);
      if (t <= max_range) hits.push_back(origin_W + t * dir);
    }
  }
  return hits;
}

/// Points on every cylinder's side (and top) surface, `step` (m) apart.
inline std::vector<Eigen::Vector3d> SurfaceSamples(const physics::ObstacleSet& set, double step) {
  std::vector<Eigen::Vector3d> pts;
  for (const auto& c : set.cylinders) {
    const int n_around = std::max(8, static_cast<int>(std::ceil(2 * std::numbers::pi * c.radius / step)));
    for (double z = c.z_min; z <= c.z_max + 1e-9; z += step) {
      for (int k = 0; k < n_around; ++k) {
        const double a = 2.0 * std::numbers::pi * k / n_around;
        pts.emplace_back(c.center_W.x() + c.radius * std::cos(a),
                         c.center_W.y() + c.radius * std::sin(a), z);
      }
    }
    for (double r = 0.0; r < c.radius; r += step) {
      const int n = std::max(1, static_cast<int>(std::ceil(2 * std::numbers::pi * r / step)));
      for (int k = 0; k < n; ++k) {
        const double a = 2.0 * std::numbers::pi * k / n;
        pts.emplace_back(c.center_W.x() + r * std::cos(a), c.center_W.y() + r * std::sin(a),
                         c.z_max);
      }
    }
  }
  return pts;
}

}  // namespace quadtune::planning::test
