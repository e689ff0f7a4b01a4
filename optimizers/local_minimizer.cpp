#include "quadtune/optimizers/local_minimizer.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <stdexcept>
#include <vector>

#include "quadtune/common/error.hpp"

namespace quadtune::optimizers {

void BoxLbfgsOptions::Validate() const {
  if (max_iterations < 1) throw ConfigError("", "max_iterations", "must be an integer >= 1");
  if (memory < 1) throw ConfigError("", "memory", "must be an integer >= 1");
  if (!(gradient_tolerance >= 0.0)) throw ConfigError("", "gradient_tolerance", "must be a number >= 0");
  if (!(relative_tolerance >= 0.0)) throw ConfigError("", "relative_tolerance", "must be a number >= 0");
  if (max_line_search < 1) throw ConfigError("", "max_line_search", "must be an integer >= 1");
}

namespace {

// Projected gradient: components pushing out of the box at an active bound are dropped.
void ProjectGradient(const Eigen::VectorXd& x, const Eigen::VectorXd& g,
                     const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                     Eigen::VectorXd* pg) {
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const bool at_low = x[i] <= lower[i] && g[i] > 0.0;
    const bool at_high = x[i] >= upper[i] && g[i] < 0.0;
    (*pg)[i] = (at_low || at_high || lower[i] == upper[i]) ? 0.0 : g[i];
  }
}

// L-BFGS two-loop recursion on the free variables: `q` = the inverse-Hessian estimate of the
// history (steps s, gradient changes y, rho = 1 / sᵀy) times `pg`; `alpha` holds one scratch
// number per history entry.
void TwoLoopRecursion(const Eigen::VectorXd& pg, const std::deque<Eigen::VectorXd>& s_hist,
                      const std::deque<Eigen::VectorXd>& y_hist, const std::deque<double>& rho_hist,
                      std::vector<double>* alpha, Eigen::VectorXd* q) {
  *q = pg;
  const std::size_t m = s_hist.size();
  for (std::size_t k = m; k-- > 0;) {
    (*alpha)[k] = rho_hist[k] * s_hist[k].dot(*q);
    *q -= (*alpha)[k] * y_hist[k];
  }
  if (m > 0) *q *= s_hist.back().dot(y_hist.back()) / y_hist.back().squaredNorm();
  for (std::size_t k = 0; k < m; ++k) {
    const double beta = rho_hist[k] * y_hist[k].dot(*q);
    *q += ((*alpha)[k] - beta) * s_hist[k];
  }
}

}  // namespace

BoxLbfgsSummary MinimizeBox(const ValueAndGradient& f, Eigen::VectorXd& x,
                            const Eigen::VectorXd& lower, const Eigen::VectorXd& upper,
                            const BoxLbfgsOptions& options) {
  options.Validate();
  const Eigen::Index n = x.size();
  if (lower.size() != n || upper.size() != n) {
    throw std::invalid_argument("MinimizeBox: x, lower and upper must have the same size");
  }
  if ((lower.array() > upper.array()).any()) throw std::invalid_argument("MinimizeBox: lower > upper");

  BoxLbfgsSummary summary;
  x = x.cwiseMax(lower).cwiseMin(upper);
  Eigen::VectorXd g(n), g_new(n), x_new(n), d(n), pg(n), q(n);
  double fx = f(x, &g);
  ++summary.evaluations;
  if (!std::isfinite(fx)) {
    summary.value = fx;
    return summary;
  }
  std::deque<Eigen::VectorXd> s_hist, y_hist;
  std::deque<double> rho_hist;
  std::vector<double> alpha(static_cast<std::size_t>(options.memory));

  for (int it = 0; it < options.max_iterations; ++it) {
    ProjectGradient(x, g, lower, upper, &pg);
    const double pg_norm = pg.cwiseAbs().maxCoeff();
    if (pg_norm <= options.gradient_tolerance) {
      summary.converged = true;
      break;
    }
    const std::size_t m = s_hist.size();
    TwoLoopRecursion(pg, s_hist, y_hist, rho_hist, &alpha, &q);
    d = -q;
    for (Eigen::Index i = 0; i < n; ++i) {
      if (pg[i] == 0.0) d[i] = 0.0;
    }
    double t = 1.0;
    if (m == 0 || d.dot(pg) >= 0.0) {
      s_hist.clear();
      y_hist.clear();
      rho_hist.clear();
      d = -pg;
      t = std::min(1.0, 1.0 / pg.norm());
    }
    // Armijo backtracking along the projected path.
    bool accepted = false;
    double f_new = fx;
    for (int ls = 0; ls < options.max_line_search; ++ls) {
      x_new = (x + t * d).cwiseMax(lower).cwiseMin(upper);
      f_new = f(x_new, &g_new);
      ++summary.evaluations;
      if (std::isfinite(f_new) && f_new <= fx + 1e-4 * g.dot(x_new - x)) {
        accepted = true;
        break;
      }
      t *= 0.5;
    }
    if (!accepted) {
      summary.converged = true;  // no further decrease along the projected direction
      break;
    }
    Eigen::VectorXd s = x_new - x;
    Eigen::VectorXd y = g_new - g;
    const double sy = s.dot(y);
    const double decrease = fx - f_new;
    x = x_new;
    g = g_new;
    fx = f_new;
    ++summary.iterations;
    if (sy > 1e-12 * s.norm() * y.norm() && sy > 0.0) {
      if (static_cast<int>(s_hist.size()) == options.memory) {
        s_hist.pop_front();
        y_hist.pop_front();
        rho_hist.pop_front();
      }
      rho_hist.push_back(1.0 / sy);
      s_hist.push_back(std::move(s));
      y_hist.push_back(std::move(y));
    }
    if (decrease <= options.relative_tolerance * std::max(1.0, std::abs(fx))) {
      summary.converged = true;
      break;
    }
  }
  summary.value = fx;
  return summary;
}

}  // namespace quadtune::optimizers
