#pragma once
/// \file
/// A small box-constrained quasi-Newton minimiser (projected L-BFGS with Armijo backtracking
/// along the projected path), used to fit Gaussian-process hyperparameters in log space and to
/// refine acquisition maxima in the unit cube.
///
/// Thread safety: stateless free function; reentrant.

#include <Eigen/Core>
#include <functional>

namespace quadtune::optimizers {

/// Objective callback: returns f(x) and, when `gradient` is not null, writes ∇f(x) into it
/// (already sized to x.size()).
using ValueAndGradient = std::function<double(const Eigen::VectorXd& x, Eigen::VectorXd* gradient)>;

/// Settings of MinimizeBox.
struct BoxLbfgsOptions {
  int max_iterations = 50;           ///< quasi-Newton iterations, >= 1
  int memory = 6;                    ///< stored correction pairs, >= 1
  double gradient_tolerance = 1e-6;  ///< stop when the projected gradient's max-norm is below, >= 0
  double relative_tolerance = 1e-10; ///< stop when a step lowers f by less than this × max(1, |f|), >= 0
  int max_line_search = 25;          ///< halvings per line search, >= 1

  /// Throws ConfigError naming the key and its range.
  void Validate() const;
};

/// Outcome of MinimizeBox.
struct BoxLbfgsSummary {
  double value = 0.0;    ///< f at the returned x
  int iterations = 0;    ///< accepted steps
  int evaluations = 0;   ///< calls of f
  bool converged = false;  ///< a tolerance was met (false: iteration limit or failed line search)
};

/// Minimises f over the box [lower, upper] starting from `x` (clamped into the box first);
/// `x` returns the best point found. Throws std::invalid_argument when the sizes differ or
/// lower > upper.
BoxLbfgsSummary MinimizeBox(const ValueAndGradient& f, Eigen::VectorXd& x,
                            const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                            const BoxLbfgsOptions& options = {});

}  // namespace quadtune::optimizers
