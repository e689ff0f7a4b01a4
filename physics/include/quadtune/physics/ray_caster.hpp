#pragma once
/// \file
/// Analytic ray casting against an ObstacleSet, for the depth sensor.
///
/// Exact intersections: ray–cylinder in closed form (side and caps), ray–torus as the first root
/// of the quartic (isolated between the roots of its derivative, refined by bracketed
/// Illinois iteration), ray–ground plane. Candidates come from a uniform 2-D grid over the
/// obstacles' xy footprints, walked cell by cell along the ray (Amanatides–Woo), stopping as soon
/// as the nearest hit lies before the current cell's exit.
///
/// Frames: everything in W. Distances in metres along unit directions.
/// Thread safety: immutable after construction; Cast() is const and safe from many threads.

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "quadtune/physics/obstacles.hpp"

namespace quadtune::physics {

/// Result of one ray.
struct RayHit {
  double distance = std::numeric_limits<double>::infinity();  ///< (m); +inf when nothing was hit
  ObstacleId obstacle;                                        ///< valid when hit()
  [[nodiscard]] bool hit() const { return distance < std::numeric_limits<double>::infinity(); }
};

/// Distance along the unit ray o + t d, t in [0, t_max], to the first point of the (solid,
/// capped) cylinder; 0 when o is inside; +inf when there is none.
[[nodiscard]] double IntersectRay(const CylinderObstacle& cylinder, const Eigen::Vector3d& o_W,
                                  const Eigen::Vector3d& d_W, double t_max);
/// Same for a ring (torus); exact to ≈1e-9 m.
[[nodiscard]] double IntersectRay(const RingObstacle& ring, const Eigen::Vector3d& o_W,
                                  const Eigen::Vector3d& d_W, double t_max);
/// Same for the ground plane z = 0 (solid below).
[[nodiscard]] double IntersectGround(const Eigen::Vector3d& o_W, const Eigen::Vector3d& d_W,
                                     double t_max);

/// Options of the acceleration grid.
struct RayCasterOptions {
  double cell_size = 0.0;  ///< grid cell edge (m); 0 = automatic (≈ sqrt(area / obstacles))
  int max_cells_per_axis = 512;  ///< upper bound on the grid resolution, >= 1

  /// Throws ConfigError naming the key and the allowed range.
  void Validate(const std::string& origin = "") const;
};

/// Fast first-hit ray caster over a copy of an ObstacleSet.
class RayCaster {
 public:
  /// An empty caster (nothing to hit).
  RayCaster() = default;
  /// Builds the grid for `obstacles` (copied).
  explicit RayCaster(const ObstacleSet& obstacles, const RayCasterOptions& options = {});

  /// First hit of the unit ray o + t d with t in [0, max_range].
  [[nodiscard]] RayHit Cast(const Eigen::Vector3d& o_W, const Eigen::Vector3d& d_W,
                            double max_range) const;

  [[nodiscard]] const ObstacleSet& obstacles() const { return obstacles_; }
  /// Heap bytes held by the grid and the obstacle copy (for memory budgets).
  [[nodiscard]] std::size_t MemoryBytes() const;

 private:
  struct RingFrame {
    Eigen::Vector3d center_W;
    Eigen::Vector3d u_W, v_W, axis_W;  // local x, y (up) and z (symmetry axis)
  };

  void TestItem(std::uint32_t item, const Eigen::Vector3d& o_W, const Eigen::Vector3d& d_W,
                RayHit& best) const;

  ObstacleSet obstacles_;
  std::vector<RingFrame> ring_frames_;
  // Grid over [origin, origin + cells * cell_size) in xy; CSR lists of item ids
  // (cylinder i -> i, ring k -> cylinders.size() + k).
  Eigen::Vector2d grid_origin_ = Eigen::Vector2d::Zero();
  double cell_size_ = 1.0;
  int nx_ = 0;
  int ny_ = 0;
  double z_lo_ = 0.0;  // vertical extent of all obstacles
  double z_hi_ = 0.0;
  std::vector<std::uint32_t> cell_start_;
  std::vector<std::uint32_t> cell_items_;
};

}  // namespace quadtune::physics
