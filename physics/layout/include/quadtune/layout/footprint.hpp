#pragma once
/// \file
/// Obstacle footprints: the projection of an obstacle onto the xy-plane of the world frame W,
/// and the distances that define the layout's non-overlap and keep-out rules.
///
/// A footprint is a capsule: the points within `radius` of the segment [a_W, b_W].
/// - CylinderObstacle: a_W = b_W = centre, radius = cylinder radius (a disc).
/// - RingObstacle (vertical torus, axis (cos yaw, sin yaw, 0)): the rim covers the segment
///   centre ± radius · (−sin yaw, cos yaw), thickened by thickness / 2. This capsule is exactly
///   the torus's projection.
///
/// Thread safety: pure functions on values.

#include <Eigen/Core>
#include <vector>

#include "quadtune/physics/obstacles.hpp"

namespace quadtune::layout {

/// A capsule in the xy-plane of W: all points within `radius` of the segment [a_W, b_W].
struct Footprint {
  Eigen::Vector2d a_W = Eigen::Vector2d::Zero();  ///< segment end (m)
  Eigen::Vector2d b_W = Eigen::Vector2d::Zero();  ///< other segment end (m)
  double radius = 0.0;                            ///< thickening (m), >= 0

  /// Centre of the segment (m).
  [[nodiscard]] Eigen::Vector2d Center() const { return 0.5 * (a_W + b_W); }
  /// Farthest distance (m) of a footprint point from Center().
  [[nodiscard]] double Reach() const { return 0.5 * (b_W - a_W).norm() + radius; }
  /// Half-extent (m) of the axis-aligned bounding box, per axis.
  [[nodiscard]] Eigen::Vector2d HalfExtent() const {
    return 0.5 * (b_W - a_W).cwiseAbs() + Eigen::Vector2d::Constant(radius);
  }

  friend bool operator==(const Footprint&, const Footprint&) = default;
};

/// Footprint of a vertical cylinder: its disc.
[[nodiscard]] Footprint FootprintOf(const physics::CylinderObstacle& cylinder);
/// Footprint of a vertical ring: the capsule its rim covers.
[[nodiscard]] Footprint FootprintOf(const physics::RingObstacle& ring);

/// Euclidean distance (m) between the segments [a0, a1] and [b0, b1] of the plane (0 when they
/// cross).
[[nodiscard]] double SegmentDistance(const Eigen::Vector2d& a0, const Eigen::Vector2d& a1,
                                     const Eigen::Vector2d& b0, const Eigen::Vector2d& b1);

/// Gap (m) between two footprints: the distance between their boundaries, negative when they
/// overlap. The layout rule is FootprintGap(f, g) >= min_gap for every pair.
[[nodiscard]] double FootprintGap(const Footprint& f, const Footprint& g);

/// Gap (m) between a footprint and the point p_W: distance from p_W to the footprint's
/// boundary, negative inside. The keep-out rule is FootprintGap(f, centre) >= radius.
[[nodiscard]] double FootprintGap(const Footprint& f, const Eigen::Vector2d& p_W);

/// Nearest-neighbour free gap (m) of every footprint in `footprints`, in input order: the
/// smallest FootprintGap to any other footprint of the list (negative when they overlap). A
/// single footprint gets +inf; none gives an empty vector. O(n²); throws Cancelled
/// (quadtune/common/cancel.hpp) once cancellation is requested.
[[nodiscard]] std::vector<double> NearestFreeGaps(const std::vector<Footprint>& footprints);

}  // namespace quadtune::layout
