#pragma once
/// \file
/// Space-filling initial designs in the unit cube.
///
/// Thread safety: free functions; each call uses only the Rng it is given.

#include <Eigen/Core>

#include "quadtune/common/random.hpp"

namespace quadtune::optimizers {

/// A Latin hypercube of n points in the box [lower, upper] ⊆ [0, 1]^d (one point per row):
/// every dimension is cut into n equal strata and each stratum holds exactly one point, placed
/// uniformly inside it; strata are paired across dimensions by random permutations.
/// Throws std::invalid_argument when n < 1, the sizes differ or lower > upper somewhere.
[[nodiscard]] Eigen::MatrixXd LatinHypercube(int n, const Eigen::VectorXd& lower,
                                             const Eigen::VectorXd& upper, Rng& rng);

/// n points drawn uniformly in [lower, upper] (one per row). Same checks as LatinHypercube.
[[nodiscard]] Eigen::MatrixXd UniformDesign(int n, const Eigen::VectorXd& lower,
                                            const Eigen::VectorXd& upper, Rng& rng);

}  // namespace quadtune::optimizers
