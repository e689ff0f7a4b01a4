#include "quadtune/optimizers/design.hpp"

#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace quadtune::optimizers {
namespace {

void CheckBox(int n, const Eigen::VectorXd& lower, const Eigen::VectorXd& upper) {
  if (n < 1) throw std::invalid_argument("design: n must be >= 1, got " + std::to_string(n));
  if (lower.size() != upper.size() || lower.size() == 0) {
    throw std::invalid_argument("design: lower and upper must have the same, non-zero size");
  }
  if ((lower.array() > upper.array()).any() || lower.hasNaN() || upper.hasNaN()) {
    throw std::invalid_argument("design: lower must not exceed upper");
  }
}

}  // namespace

Eigen::MatrixXd LatinHypercube(int n, const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                               Rng& rng) {
  CheckBox(n, lower, upper);
  const Eigen::Index d = lower.size();
  Eigen::MatrixXd points(n, d);
  std::vector<int> perm(static_cast<std::size_t>(n));
  for (Eigen::Index j = 0; j < d; ++j) {
    std::iota(perm.begin(), perm.end(), 0);
    for (int i = n - 1; i > 0; --i) {  // Fisher–Yates with the portable UniformInt
      const auto r = static_cast<std::size_t>(UniformInt(rng, 0, i));
      std::swap(perm[static_cast<std::size_t>(i)], perm[r]);
    }
    for (int i = 0; i < n; ++i) {
      const double t = (perm[static_cast<std::size_t>(i)] + Uniform01(rng)) / n;
      points(i, j) = lower[j] + t * (upper[j] - lower[j]);
    }
  }
  return points;
}

Eigen::MatrixXd UniformDesign(int n, const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                              Rng& rng) {
  CheckBox(n, lower, upper);
  const Eigen::Index d = lower.size();
  Eigen::MatrixXd points(n, d);
  for (int i = 0; i < n; ++i) {
    for (Eigen::Index j = 0; j < d; ++j) points(i, j) = Uniform(rng, lower[j], upper[j]);
  }
  return points;
}

}  // namespace quadtune::optimizers
