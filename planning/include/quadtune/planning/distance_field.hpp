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

  /// The distance (m) that the trajectory optimiser's collision cost reads, with its gradient
  /// (*grad_W, 1) and Hessian (*hess_W, 1/m; symmetric) when the pointers are not null.
  ///
  /// Newton's method on the cost converges quadratically only when this function is C² and its
  /// Hessian is exact; the exact nearest-obstacle distance is not (its gradient jumps on the
  /// ridges between obstacles, and a trilinear ESDF's across voxel faces). An implementation
  /// should therefore return a C² approximation of Evaluate() with its exact derivatives (a
  /// soft-min over obstacles, a tricubic B-spline of ESDF samples) that never exceeds Evaluate()
  /// by more than a small, documented margin (under-estimating is the safe side). The
  /// post-solve collision check keeps using Evaluate().
  ///
  /// Default: Evaluate() with a zero Hessian, i.e. the optimiser falls back to Gauss–Newton for
  /// the collision term (correct, but linearly convergent and slower).
  /// Thread safety: as Evaluate().
  virtual double EvaluateWithHessian(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W,
                                     Eigen::Matrix3d* hess_W) const {
    if (hess_W != nullptr) hess_W->setZero();
    return Evaluate(p_W, grad_W);
  }

  /// EvaluateWithHessian(p_W, grad_W, hess_W) into *distance, returning true, unless a bound
  /// cheaper than the evaluation shows that the distance is at least `threshold` (m): then it
  /// returns false and writes nothing. A caller whose cost vanishes above a threshold (the
  /// collision penalty beyond the clearance) skips such points without changing its result.
  /// Default: always evaluates.
  /// Thread safety: as Evaluate().
  virtual bool EvaluateWithHessianBelow(const Eigen::Vector3d& p_W, double /*threshold*/,
                                        double* distance, Eigen::Vector3d* grad_W,
                                        Eigen::Matrix3d* hess_W) const {
    *distance = EvaluateWithHessian(p_W, grad_W, hess_W);
    return true;
  }

  /// True when EvaluateWithHessian() returns a C² distance with its exact Hessian (an override as
  /// described there); false (the default) for a field that only offers Evaluate(). The
  /// optimiser then knows that its Newton model is exact, and arms its stagnation safeguard
  /// for non-smooth fields only (TrajectoryOptimizerOptions::stall_relative_change).
  [[nodiscard]] virtual bool ProvidesCurvature() const { return false; }
};

}  // namespace quadtune::planning
