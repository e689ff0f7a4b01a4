#pragma once
/// \file
/// The read-only distance query that the trajectory optimiser's collision cost needs. The local
/// map's Euclidean distance field implements it; tests may implement it analytically.

#include <Eigen/Core>

namespace quadtune::planning {

/// Distance (m) from a world-frame point to the nearest obstacle, with its gradient.
///
/// Thread safety: implementations must allow concurrent Evaluate() calls on one const object.
class DistanceField {
 public:
  virtual ~DistanceField() = default;
  DistanceField() = default;
  DistanceField(const DistanceField&) = default;
  DistanceField& operator=(const DistanceField&) = default;
  DistanceField(DistanceField&&) = default;
  DistanceField& operator=(DistanceField&&) = default;

  /// Distance (m) at p_W; writes d(distance)/d(p_W) into *grad_W when grad_W is not null.
  /// Points outside the known region return a large positive distance with zero gradient.
  virtual double Evaluate(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W) const = 0;
};

}  // namespace quadtune::planning
