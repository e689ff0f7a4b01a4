#pragma once
// Standard test functions for the optimizer tests and benchmarks (minimisation).

#include <Eigen/Core>
#include <cmath>
#include <numbers>

#include "quadtune/optimizers/parameter_space.hpp"

namespace quadtune::optimizers::testing {

/// Branin on [-5, 10] × [0, 15]; global minimum 0.397887357729738 (three minimisers).
inline double Branin(const Eigen::VectorXd& x) {
  const double pi = std::numbers::pi;
  const double a = 1.0, b = 5.1 / (4.0 * pi * pi), c = 5.0 / pi, r = 6.0, s = 10.0, t = 1.0 / (8.0 * pi);
  const double y = x[1] - b * x[0] * x[0] + c * x[0] - r;
  return a * y * y + s * (1.0 - t) * std::cos(x[0]) + s;
}
inline constexpr double kBraninMin = 0.397887357729738;

/// Hartmann-6 on [0, 1]^6; global minimum −3.32236801141551.
inline double Hartmann6(const Eigen::VectorXd& x) {
  static const double alpha[4] = {1.0, 1.2, 3.0, 3.2};
  static const double a[4][6] = {{10, 3, 17, 3.5, 1.7, 8},
                                 {0.05, 10, 17, 0.1, 8, 14},
                                 {3, 3.5, 1.7, 10, 17, 8},
                                 {17, 8, 0.05, 10, 0.1, 14}};
  static const double p[4][6] = {{0.1312, 0.1696, 0.5569, 0.0124, 0.8283, 0.5886},
                                 {0.2329, 0.4135, 0.8307, 0.3736, 0.1004, 0.9991},
                                 {0.2348, 0.1451, 0.3522, 0.2883, 0.3047, 0.6650},
                                 {0.4047, 0.8828, 0.8732, 0.5743, 0.1091, 0.0381}};
  double sum = 0.0;
  for (int i = 0; i < 4; ++i) {
    double inner = 0.0;
    for (int j = 0; j < 6; ++j) inner += a[i][j] * (x[j] - p[i][j]) * (x[j] - p[i][j]);
    sum += alpha[i] * std::exp(-inner);
  }
  return -sum;
}
inline constexpr double kHartmann6Min = -3.32236801141551;

/// Sphere Σ x_i², minimum 0 at the origin.
inline double Sphere(const Eigen::VectorXd& x) { return x.squaredNorm(); }

/// Rosenbrock Σ 100 (x_{i+1} − x_i²)² + (1 − x_i)², minimum 0 at (1, …, 1).
inline double Rosenbrock(const Eigen::VectorXd& x) {
  double f = 0.0;
  for (Eigen::Index i = 0; i + 1 < x.size(); ++i) {
    f += 100.0 * std::pow(x[i + 1] - x[i] * x[i], 2) + std::pow(1.0 - x[i], 2);
  }
  return f;
}

/// A box space named x0, x1, … with the given bounds.
inline ParameterSpace BoxSpace(int dim, double lower, double upper) {
  std::vector<Parameter> params;
  for (int i = 0; i < dim; ++i) {
    Parameter p;
    p.name = "x" + std::to_string(i);
    p.lower = lower;
    p.upper = upper;
    params.push_back(p);
  }
  return ParameterSpace(std::move(params));
}

inline ParameterSpace BraninSpace() {
  Parameter a;
  a.name = "x0";
  a.lower = -5.0;
  a.upper = 10.0;
  Parameter b;
  b.name = "x1";
  b.lower = 0.0;
  b.upper = 15.0;
  return ParameterSpace({a, b});
}

}  // namespace quadtune::optimizers::testing
