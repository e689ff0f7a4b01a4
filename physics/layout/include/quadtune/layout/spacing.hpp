#pragma once
/// \file
/// Measurement of obstacle spacing: nearest-neighbour (NN) distances between obstacle centres
/// in the xy-plane of the world frame W, computed with a CGAL Delaunay triangulation (every NN
/// pair is a Delaunay edge), O(n log n).
///
/// Thread safety: pure functions on values.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace quadtune::layout {

/// Statistics of the nearest-neighbour distances of a point set (m).
/// With fewer than two points every number is 0.
struct SpacingStats {
  std::size_t count = 0;  ///< number of points
  double mean = 0.0;      ///< mean NN distance (m): the "average spacing"
  double std = 0.0;       ///< population standard deviation of the NN distances (m)
  double min = 0.0;       ///< smallest NN distance (m)
  double max = 0.0;       ///< largest NN distance (m)

  friend bool operator==(const SpacingStats&, const SpacingStats&) = default;
};

/// Nearest-neighbour distance (m) of every point in `points_W` (xy, m), in input order.
/// Coincident points have NN distance 0; a single point gets +inf; none gives an empty vector.
/// Throws Cancelled (quadtune/common/cancel.hpp) once cancellation is requested.
[[nodiscard]] std::vector<double> NearestNeighbourDistances(
    const std::vector<Eigen::Vector2d>& points_W);

/// SpacingStats of a list of nearest-neighbour distances (m), e.g. NearestFreeGaps.
[[nodiscard]] SpacingStats StatsOf(const std::vector<double>& distances);

/// SpacingStats of `points_W` (xy positions in W, m).
[[nodiscard]] SpacingStats MeasureSpacing(const std::vector<Eigen::Vector2d>& points_W);

}  // namespace quadtune::layout
