#include "quadtune/optimizers/gaussian_process.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <algorithm>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "quadtune/common/error.hpp"

namespace quadtune::optimizers {

const Fields<GaussianProcessOptions>& GpFields() {
  using O = GaussianProcessOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Number("min_lengthscale", &O::min_lengthscale, Range::Positive(),
                  "smallest lengthscale (unit-cube widths)")
          .Number("max_lengthscale", &O::max_lengthscale, Range::Positive(),
                  "largest lengthscale, > `min_lengthscale`")
          .Number("min_signal_std", &O::min_signal_std, Range::Positive(),
                  "smallest signal standard deviation σ_f (standardised units)")
          .Number("max_signal_std", &O::max_signal_std, Range::Positive(),
                  "largest σ_f, > `min_signal_std`")
          .Number("min_noise_std", &O::min_noise_std, Range::Positive(),
                  "smallest noise standard deviation σ_n (standardised units; also the jitter "
                  "that keeps the covariance positive definite)")
          .Number("max_noise_std", &O::max_noise_std, Range::Positive(),
                  "largest σ_n, ≥ `min_noise_std`")
          .Flag("learn_noise", &O::learn_noise, "false: σ_n stays at `initial_noise_std`")
          .Number("initial_lengthscale", &O::initial_lengthscale, Range::Positive(),
                  "start of the first fit, inside the lengthscale bounds")
          .Number("initial_noise_std", &O::initial_noise_std, Range::Positive(),
                  "start of the first fit, inside the noise bounds")
          .Integer("fit_iterations", &O::fit_iterations, Range::Closed(1, 1e5),
                   "L-BFGS iterations per start");
  return fields;
}

void GaussianProcessOptions::Validate(const std::string& file, const std::string& prefix) const {
  GpFields().Check(*this, file, prefix);
  if (!(max_lengthscale > min_lengthscale)) {
    throw ConfigError(file, prefix + "max_lengthscale",
                      "must be a finite number > " + prefix + "min_lengthscale");
  }
  if (!(max_signal_std > min_signal_std)) {
    throw ConfigError(file, prefix + "max_signal_std",
                      "must be a finite number > " + prefix + "min_signal_std");
  }
  if (!(max_noise_std >= min_noise_std)) {
    throw ConfigError(file, prefix + "max_noise_std",
                      "must be a finite number >= " + prefix + "min_noise_std");
  }
  if (!(initial_lengthscale >= min_lengthscale && initial_lengthscale <= max_lengthscale)) {
    throw ConfigError(file, prefix + "initial_lengthscale",
                      "must lie in [" + prefix + "min_lengthscale, " + prefix + "max_lengthscale]");
  }
  if (!(initial_noise_std >= min_noise_std && initial_noise_std <= max_noise_std)) {
    throw ConfigError(file, prefix + "initial_noise_std",
                      "must lie in [" + prefix + "min_noise_std, " + prefix + "max_noise_std]");
  }
}

namespace {

/// r²_ij = |a_i − b_j|² for the columns of already scaled inputs a (d × n) and b (d × m).
Eigen::ArrayXXd SquaredDistances(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  Eigen::MatrixXd r2 = -2.0 * (a.transpose() * b);
  r2.colwise() += a.colwise().squaredNorm().transpose();
  r2.rowwise() += b.colwise().squaredNorm();
  return r2.array().max(0.0);
}

}  // namespace

template <class Kernel>
GaussianProcess<Kernel>::GaussianProcess(int dim, GaussianProcessOptions options)
    : dim_(dim), options_(options) {
  if (dim < 1) throw std::invalid_argument("GaussianProcess: dimension must be >= 1, got " + std::to_string(dim));
  options_.Validate();
  hyper_.log_lengthscales = Eigen::VectorXd::Constant(dim, std::log(options_.initial_lengthscale));
  hyper_.log_signal_std = 0.0;
  hyper_.log_noise_std = std::log(options_.initial_noise_std);
  inv_l2_ = (-2.0 * hyper_.log_lengthscales).array().exp();
  Reserve(16);
}

template <class Kernel>
void GaussianProcess<Kernel>::Reserve(int capacity) {
  if (capacity <= inputs_.cols()) return;
  const int cap = std::max(capacity, static_cast<int>(2 * inputs_.cols()));
  inputs_.conservativeResize(dim_, cap);
  targets_.conservativeResize(cap);
  noise_.conservativeResize(cap);
  multiplier_.conservativeResize(cap);
  beta_.conservativeResize(cap);
  chol_.conservativeResize(cap, cap);
}

template <class Kernel>
void GaussianProcess<Kernel>::SetData(const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets,
                                      const Eigen::VectorXd& noise_variances,
                                      const Eigen::VectorXd& noise_multipliers) {
  const Eigen::Index n = inputs.rows();
  if (inputs.cols() != dim_ && n > 0) {
    throw std::invalid_argument("GaussianProcess::SetData: inputs need " + std::to_string(dim_) + " columns");
  }
  if (targets.size() != n || noise_variances.size() != n ||
      (noise_multipliers.size() != 0 && noise_multipliers.size() != n)) {
    throw std::invalid_argument("GaussianProcess::SetData: inputs, targets and noise sizes differ");
  }
  if (!inputs.allFinite() || !targets.allFinite() || !noise_variances.allFinite() ||
      (noise_variances.array() < 0.0).any() || !noise_multipliers.allFinite() ||
      (noise_multipliers.array() < 1.0).any()) {
    throw std::invalid_argument("GaussianProcess::SetData: non-finite or out-of-range values");
  }
  Reserve(static_cast<int>(n));
  n_ = static_cast<int>(n);
  y_mean_ = n > 0 ? targets.mean() : 0.0;
  y_scale_ = 1.0;
  if (n >= 2) {
    const double sd = std::sqrt((targets.array() - y_mean_).square().sum() / static_cast<double>(n - 1));
    if (sd > 1e-12 * std::max(1.0, std::abs(y_mean_))) y_scale_ = sd;
  }
  const double s2 = y_scale_ * y_scale_;
  for (int j = 0; j < n_; ++j) {
    inputs_.col(j) = inputs.row(j).transpose();
    targets_[j] = (targets[j] - y_mean_) / y_scale_;
    noise_[j] = noise_variances[j] / s2;
    multiplier_[j] = noise_multipliers.size() ? noise_multipliers[j] : 1.0;
  }
  Refactorize();
}

template <class Kernel>
double GaussianProcess<Kernel>::KernelValue(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const {
  const double r2 = ((a - b).array().square() * inv_l2_.array()).sum();
  return SignalVariance() * Kernel::Value(r2);
}

template <class Kernel>
void GaussianProcess<Kernel>::Refactorize() {
  const int n = n_;
  if (n == 0) {
    alpha_.resize(0);
    return;
  }
  const double sf2 = SignalVariance();
  const double sn2 = std::exp(2.0 * hyper_.log_noise_std);
  const Eigen::MatrixXd z = inv_l2_.array().sqrt().matrix().asDiagonal() * inputs_.leftCols(n);
  Eigen::ArrayXXd r2 = SquaredDistances(z, z);
  r2.matrix().diagonal().setZero();
  Eigen::ArrayXXd phi;
  Kernel::Evaluate(r2, &phi, nullptr);
  Eigen::MatrixXd k = sf2 * phi.matrix();
  for (int j = 0; j < n; ++j) k(j, j) += multiplier_[j] * (sn2 + noise_[j]);
  double jitter = 0.0;
  for (int attempt = 0; attempt < 8; ++attempt) {
    Eigen::MatrixXd a = k;
    if (jitter > 0.0) a.diagonal().array() += jitter;
    Eigen::LLT<Eigen::Ref<Eigen::MatrixXd>, Eigen::Lower> llt(a);
    if (llt.info() == Eigen::Success) {
      chol_.topLeftCorner(n, n).template triangularView<Eigen::Lower>() = a.template triangularView<Eigen::Lower>();
      auto l = chol_.topLeftCorner(n, n).template triangularView<Eigen::Lower>();
      beta_.head(n) = l.solve(targets_.head(n));
      alpha_ = l.transpose().solve(beta_.head(n));
      return;
    }
    jitter = jitter == 0.0 ? 1e-10 * sf2 : jitter * 100.0;
  }
  throw InvariantError("GaussianProcess: covariance matrix is not positive definite");
}

template <class Kernel>
void GaussianProcess<Kernel>::Append(const Eigen::VectorXd& input, double target, double noise_variance,
                                     double noise_multiplier) {
  if (input.size() != dim_ || !input.allFinite() || !std::isfinite(target) ||
      !(noise_variance >= 0.0) || !std::isfinite(noise_variance) || !(noise_multiplier >= 1.0) ||
      !std::isfinite(noise_multiplier)) {
    throw std::invalid_argument("GaussianProcess::Append: wrong size or out-of-range values");
  }
  Reserve(n_ + 1);
  const int n = n_;
  inputs_.col(n) = input;
  targets_[n] = (target - y_mean_) / y_scale_;
  noise_[n] = noise_variance / (y_scale_ * y_scale_);
  multiplier_[n] = noise_multiplier;
  const double sf2 = SignalVariance();
  const double sn2 = std::exp(2.0 * hyper_.log_noise_std);
  double diag = sf2 + noise_multiplier * (sn2 + noise_[n]);
  if (n > 0) {
    Eigen::VectorXd kv(n);
    for (int j = 0; j < n; ++j) kv[j] = KernelValue(inputs_.col(j), input);
    chol_.topLeftCorner(n, n).template triangularView<Eigen::Lower>().solveInPlace(kv);
    chol_.row(n).head(n) = kv.transpose();
    diag -= kv.squaredNorm();
    const double lnn = std::sqrt(std::max(diag, 1e-12 * sf2));
    chol_(n, n) = lnn;
    beta_[n] = (targets_[n] - kv.dot(beta_.head(n))) / lnn;
  } else {
    chol_(0, 0) = std::sqrt(diag);
    beta_[0] = targets_[0] / chol_(0, 0);
  }
  n_ = n + 1;
  alpha_ = chol_.topLeftCorner(n_, n_).template triangularView<Eigen::Lower>().transpose().solve(beta_.head(n_));
}

template <class Kernel>
void GaussianProcess<Kernel>::Truncate(int n) {
  if (n < 0 || n > n_) throw std::invalid_argument("GaussianProcess::Truncate: n out of range");
  n_ = n;
  if (n == 0) {
    alpha_.resize(0);
    return;
  }
  alpha_ = chol_.topLeftCorner(n, n).template triangularView<Eigen::Lower>().transpose().solve(beta_.head(n));
}

template <class Kernel>
double GaussianProcess<Kernel>::NoiseVariance(int j) const {
  if (j < 0 || j >= n_) throw std::invalid_argument("GaussianProcess::NoiseVariance: index out of range");
  const double sn2 = std::exp(2.0 * hyper_.log_noise_std);
  return multiplier_[j] * (sn2 + noise_[j]) * y_scale_ * y_scale_;
}

template <class Kernel>
Eigen::VectorXd GaussianProcess<Kernel>::PosteriorMeanAtData() const {
  const double sn2 = std::exp(2.0 * hyper_.log_noise_std);
  Eigen::VectorXd out(n_);
  for (int j = 0; j < n_; ++j) out[j] = targets_[j] - multiplier_[j] * (sn2 + noise_[j]) * alpha_[j];
  return out;
}

template <class Kernel>
Eigen::VectorXd GaussianProcess<Kernel>::PackedHyperparameters() const {
  Eigen::VectorXd p(dim_ + 2);
  p.head(dim_) = hyper_.log_lengthscales;
  p[dim_] = hyper_.log_signal_std;
  p[dim_ + 1] = hyper_.log_noise_std;
  return p;
}

template <class Kernel>
void GaussianProcess<Kernel>::BoxBounds(Eigen::VectorXd* lower, Eigen::VectorXd* upper) const {
  lower->resize(dim_ + 2);
  upper->resize(dim_ + 2);
  lower->head(dim_).setConstant(std::log(options_.min_lengthscale));
  upper->head(dim_).setConstant(std::log(options_.max_lengthscale));
  (*lower)[dim_] = std::log(options_.min_signal_std);
  (*upper)[dim_] = std::log(options_.max_signal_std);
  if (options_.learn_noise) {
    (*lower)[dim_ + 1] = std::log(options_.min_noise_std);
    (*upper)[dim_ + 1] = std::log(options_.max_noise_std);
  } else {
    (*lower)[dim_ + 1] = (*upper)[dim_ + 1] = hyper_.log_noise_std;
  }
}

template <class Kernel>
void GaussianProcess<Kernel>::SetHyperparameters(const GpHyperparameters& hyper) {
  if (hyper.log_lengthscales.size() != dim_ || !hyper.log_lengthscales.allFinite() ||
      !std::isfinite(hyper.log_signal_std) || !std::isfinite(hyper.log_noise_std)) {
    throw std::invalid_argument("GaussianProcess::SetHyperparameters: wrong size or non-finite values");
  }
  Eigen::VectorXd lo, hi;
  BoxBounds(&lo, &hi);
  if (!options_.learn_noise) {
    lo[dim_ + 1] = std::log(options_.min_noise_std);
    hi[dim_ + 1] = std::log(options_.max_noise_std);
  }
  hyper_.log_lengthscales = hyper.log_lengthscales.cwiseMax(lo.head(dim_)).cwiseMin(hi.head(dim_));
  hyper_.log_signal_std = std::clamp(hyper.log_signal_std, lo[dim_], hi[dim_]);
  hyper_.log_noise_std = std::clamp(hyper.log_noise_std, lo[dim_ + 1], hi[dim_ + 1]);
  inv_l2_ = (-2.0 * hyper_.log_lengthscales).array().exp();
  Refactorize();
}

template <class Kernel>
double GaussianProcess<Kernel>::LogMarginalLikelihood(const Eigen::VectorXd& p, Eigen::VectorXd* gradient) const {
  if (p.size() != dim_ + 2) throw std::invalid_argument("GaussianProcess::LogMarginalLikelihood: wrong size");
  const int n = n_;
  if (gradient) gradient->setZero(dim_ + 2);
  if (n == 0) return 0.0;
  const Eigen::ArrayXd inv_l = (-p.head(dim_)).array().exp();
  const double sf2 = std::exp(2.0 * p[dim_]);
  const double sn2 = std::exp(2.0 * p[dim_ + 1]);
  const Eigen::MatrixXd z = inv_l.matrix().asDiagonal() * inputs_.leftCols(n);
  Eigen::ArrayXXd r2 = SquaredDistances(z, z);
  r2.matrix().diagonal().setZero();
  Eigen::ArrayXXd phi, dphi;
  Kernel::Evaluate(r2, &phi, gradient ? &dphi : nullptr);
  Eigen::MatrixXd sigma = sf2 * phi.matrix();
  for (int j = 0; j < n; ++j) sigma(j, j) += multiplier_[j] * (sn2 + noise_[j]);
  Eigen::LLT<Eigen::MatrixXd, Eigen::Lower> llt(sigma);
  if (llt.info() != Eigen::Success) return -std::numeric_limits<double>::infinity();
  const Eigen::VectorXd y = targets_.head(n);
  const Eigen::VectorXd alpha = llt.solve(y);
  const auto l = llt.matrixL();
  double log_det_half = 0.0;
  for (int j = 0; j < n; ++j) log_det_half += std::log(llt.matrixLLT()(j, j));
  const double lml = -0.5 * y.dot(alpha) - log_det_half - 0.5 * n * std::log(2.0 * std::numbers::pi);
  if (!gradient) return lml;

  // W = α αᵀ − Σ⁻¹, with Σ⁻¹ = L⁻ᵀ L⁻¹; ∂/∂θ_i = ½ Σ_jk W_jk ∂Σ_jk/∂θ_i.
  Eigen::MatrixXd linv = Eigen::MatrixXd::Identity(n, n);
  l.solveInPlace(linv);
  Eigen::MatrixXd w = Eigen::MatrixXd::Zero(n, n);
  w.template selfadjointView<Eigen::Lower>().rankUpdate(linv.transpose(), -1.0);
  w.template selfadjointView<Eigen::Lower>().rankUpdate(alpha, 1.0);
  w.template triangularView<Eigen::StrictlyUpper>() = w.transpose();
  Eigen::VectorXd& g = *gradient;
  // Signal: ∂Σ/∂ln σ_f = 2 σ_f² φ.  Noise: ∂Σ_jj/∂ln σ_n = 2 σ_n² m_j.
  const double g_sf = sf2 * (w.array() * phi).sum();
  const double g_sn = (w.diagonal().array() * multiplier_.head(n).array()).sum();
  // Lengthscales: ∂Σ_ij/∂ln ℓ_k = −2 σ_f² φ'_ij (z_ik − z_jk)², so with A = σ_f² W ∘ φ',
  // ∂/∂ln ℓ_k = −Σ_ij A_ij (z_ik − z_jk)² = −2 (Σ_i z_ik² (A1)_i − z_kᵀ A z_k).
  const Eigen::MatrixXd a = sf2 * (w.array() * dphi).matrix();
  const Eigen::VectorXd row_sum = a.rowwise().sum();
  const Eigen::MatrixXd az = a * z.transpose();  // n × d
  for (int k = 0; k < dim_; ++k) {
    g[k] = -2.0 * (z.row(k).array().square().matrix().dot(row_sum) - z.row(k).dot(az.col(k)));
  }
  g[dim_] = g_sf;
  g[dim_ + 1] = options_.learn_noise ? sn2 * g_sn : 0.0;
  return lml;
}

template <class Kernel>
GpFitSummary GaussianProcess<Kernel>::Fit(Rng& rng, int random_restarts) {
  GpFitSummary summary;
  if (n_ == 0) return summary;
  Eigen::VectorXd lo, hi;
  BoxBounds(&lo, &hi);
  const ValueAndGradient objective = [this](const Eigen::VectorXd& p, Eigen::VectorXd* g) {
    const double v = LogMarginalLikelihood(p, g);
    if (g) *g = -*g;
    return -v;
  };
  BoxLbfgsOptions lbfgs;
  lbfgs.max_iterations = options_.fit_iterations;
  // A likelihood gain below ~1e-3 nats does not change the surrogate noticeably.
  lbfgs.gradient_tolerance = 1e-3;
  lbfgs.relative_tolerance = 1e-5;
  Eigen::VectorXd best = PackedHyperparameters().cwiseMax(lo).cwiseMin(hi);
  double best_value = std::numeric_limits<double>::infinity();
  for (int start = 0; start <= std::max(0, random_restarts); ++start) {
    Eigen::VectorXd p = best;
    if (start == 0) {
      p = PackedHyperparameters().cwiseMax(lo).cwiseMin(hi);
    } else {
      for (int k = 0; k < dim_; ++k) p[k] = Uniform(rng, std::log(0.05), std::log(2.0));
      p[dim_] = Uniform(rng, std::log(0.5), std::log(2.0));
      if (options_.learn_noise) p[dim_ + 1] = Uniform(rng, std::log(1e-3), std::log(0.3));
      p = p.cwiseMax(lo).cwiseMin(hi);
    }
    const BoxLbfgsSummary s = MinimizeBox(objective, p, lo, hi, lbfgs);
    ++summary.starts;
    summary.evaluations += s.evaluations;
    if (s.value < best_value) {
      best_value = s.value;
      best = p;
    }
  }
  hyper_.log_lengthscales = best.head(dim_);
  hyper_.log_signal_std = best[dim_];
  hyper_.log_noise_std = best[dim_ + 1];
  inv_l2_ = (-2.0 * hyper_.log_lengthscales).array().exp();
  Refactorize();
  summary.log_marginal_likelihood = -best_value;
  return summary;
}

template <class Kernel>
void GaussianProcess<Kernel>::PredictStandardized(const Eigen::VectorXd& u, double* mean, double* variance,
                                                  Eigen::VectorXd* mean_gradient,
                                                  Eigen::VectorXd* variance_gradient) const {
  if (u.size() != dim_) throw std::invalid_argument("GaussianProcess::Predict: wrong input size");
  const double sf2 = SignalVariance();
  const int n = n_;
  const bool grad = mean_gradient != nullptr || variance_gradient != nullptr;
  if (n == 0) {
    if (mean) *mean = 0.0;
    if (variance) *variance = sf2;
    if (mean_gradient) mean_gradient->setZero(dim_);
    if (variance_gradient) variance_gradient->setZero(dim_);
    return;
  }
  Eigen::VectorXd k(n);
  Eigen::MatrixXd dk(grad ? n : 0, grad ? dim_ : 0);
  for (int j = 0; j < n; ++j) {
    const Eigen::ArrayXd diff = u.array() - inputs_.col(j).array();
    const double r2 = (diff.square() * inv_l2_.array()).sum();
    k[j] = sf2 * Kernel::Value(r2);
    if (grad) dk.row(j) = (2.0 * sf2 * Kernel::DerivativeR2(r2)) * (diff * inv_l2_.array()).matrix().transpose();
  }
  if (mean) *mean = k.dot(alpha_);
  if (mean_gradient) *mean_gradient = dk.transpose() * alpha_;
  if (variance || variance_gradient) {
    const auto l = chol_.topLeftCorner(n, n).template triangularView<Eigen::Lower>();
    Eigen::VectorXd v = l.solve(k);
    const double var = sf2 - v.squaredNorm();
    const double floor = 1e-12 * sf2;
    if (variance) *variance = std::max(var, floor);
    if (variance_gradient) {
      if (var <= floor) {
        variance_gradient->setZero(dim_);
      } else {
        l.transpose().solveInPlace(v);
        *variance_gradient = -2.0 * (dk.transpose() * v);
      }
    }
  }
}

template <class Kernel>
void GaussianProcess<Kernel>::Predict(const Eigen::VectorXd& u, double* mean, double* variance) const {
  double m = 0.0;
  double v = 0.0;
  PredictStandardized(u, &m, &v, nullptr, nullptr);
  if (mean) *mean = y_mean_ + y_scale_ * m;
  if (variance) *variance = v * y_scale_ * y_scale_;
}

template <class Kernel>
void GaussianProcess<Kernel>::PredictPool(const Eigen::MatrixXd& points, Eigen::MatrixXd* v,
                                          Eigen::VectorXd* mean, Eigen::VectorXd* variance) const {
  if (points.rows() != dim_) throw std::invalid_argument("GaussianProcess::PredictPool: wrong point size");
  const Eigen::Index m = points.cols();
  const double sf2 = SignalVariance();
  const int n = n_;
  Eigen::MatrixXd kq(n, m);
  const Eigen::ArrayXd inv_l = inv_l2_.array().sqrt();
  const Eigen::MatrixXd zq = inv_l.matrix().asDiagonal() * points;
  const Eigen::MatrixXd zd = inv_l.matrix().asDiagonal() * inputs_.leftCols(n);
  if (n > 0) {
    Eigen::ArrayXXd phi;
    Kernel::Evaluate(SquaredDistances(zd, zq), &phi, nullptr);
    kq = sf2 * phi.matrix();
  }
  *mean = kq.transpose() * alpha_;
  if (n > 0) chol_.topLeftCorner(n, n).template triangularView<Eigen::Lower>().solveInPlace(kq);
  *variance = (sf2 - kq.colwise().squaredNorm().array()).max(1e-12 * sf2).matrix().transpose();
  *v = std::move(kq);
  if (n == 0) mean->setZero(m);
}

template <class Kernel>
void GaussianProcess<Kernel>::ExtendPool(const Eigen::MatrixXd& points, Eigen::MatrixXd* v,
                                         Eigen::VectorXd* mean, Eigen::VectorXd* variance) const {
  const Eigen::Index m = points.cols();
  const int old_rows = static_cast<int>(v->rows());
  if (points.rows() != dim_ || v->cols() != m || old_rows > n_) {
    throw std::invalid_argument("GaussianProcess::ExtendPool: pool does not match");
  }
  const double sf2 = SignalVariance();
  v->conservativeResize(n_, m);
  for (int r = old_rows; r < n_; ++r) {
    Eigen::RowVectorXd row(m);
    for (Eigen::Index c = 0; c < m; ++c) row[c] = KernelValue(inputs_.col(r), points.col(c));
    if (r > 0) row.noalias() -= chol_.row(r).head(r) * v->topRows(r);
    row /= chol_(r, r);
    v->row(r) = row;
    *mean += beta_[r] * row.transpose();
    *variance -= row.transpose().cwiseAbs2();
  }
  *variance = variance->cwiseMax(1e-12 * sf2);
}

template class GaussianProcess<SquaredExponentialKernel>;
template class GaussianProcess<Matern52Kernel>;

}  // namespace quadtune::optimizers
