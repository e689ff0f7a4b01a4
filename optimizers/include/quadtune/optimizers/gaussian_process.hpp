#pragma once
/// \file
/// Gaussian-process regression for Bayesian optimisation (paper Sec. III-C, Eq. for the GP
/// posterior and the noisy covariance Σ = K + diag(σ²_ω)).
///
/// Model, in normalised coordinates:
///  - inputs u ∈ [0, 1]^d (unit cube of a ParameterSpace);
///  - outputs standardised, ỹ = (y − m_y) / s_y with m_y, s_y the mean and standard deviation of
///    the data given to SetData (s_y = 1 with fewer than two distinct values); the constant
///    prior mean is m_y (0 in standardised units);
///  - ARD kernel k(u, u') = σ_f² φ(r²), r² = Σ_k ((u_k − u'_k) / ℓ_k)², with φ from the Kernel
///    type (compile-time choice): SquaredExponentialKernel φ = exp(−r²/2),
///    Matern52Kernel φ = (1 + √5 r + 5r²/3) exp(−√5 r);
///  - per-observation noise: Σ_jj = k(u_j, u_j) + m_j (σ_n² + v_j / s_y²), where v_j is the
///    observation's own noise variance (objective units², ≥ 0), m_j ≥ 1 its noise multiplier
///    (discounting and ageing, see bayes_opt.hpp) and σ_n a learned (or fixed) noise floor.
///
/// Hyperparameters θ = (ln ℓ_1..ln ℓ_d, ln σ_f, ln σ_n) maximise the log marginal likelihood
///   ln p(ỹ | θ) = −½ ỹᵀ Σ⁻¹ ỹ − ½ ln |Σ| − (n/2) ln 2π,
/// with the analytic gradient ∂/∂θ_i = ½ tr((α αᵀ − Σ⁻¹) ∂Σ/∂θ_i), α = Σ⁻¹ ỹ, by projected
/// L-BFGS in log space from a warm start (the previous θ) and optional random restarts.
///
/// The Cholesky factor L (Σ = L Lᵀ) is rebuilt by SetData / SetHyperparameters / Fit and
/// extended by one row in O(n²) by Append (fantasy or new data with the scaling kept fixed);
/// Truncate drops trailing rows in O(1).
///
/// Thread safety: a value type; const methods may run concurrently, others need exclusive use.

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <string_view>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/optimizers/local_minimizer.hpp"

namespace quadtune::optimizers {

/// Squared-exponential correlation φ(r²) = exp(−r²/2).
struct SquaredExponentialKernel {
  static constexpr std::string_view kName = "squared_exponential";
  /// φ(r²).
  static double Value(double r2) { return std::exp(-0.5 * r2); }
  /// dφ/d(r²).
  static double DerivativeR2(double r2) { return -0.5 * std::exp(-0.5 * r2); }
  /// Vectorised φ and (when not null) dφ/d(r²) of a whole array of r² values.
  static void Evaluate(const Eigen::ArrayXXd& r2, Eigen::ArrayXXd* value, Eigen::ArrayXXd* derivative) {
    *value = (-0.5 * r2).exp();
    if (derivative) *derivative = -0.5 * *value;
  }
};

/// Matérn-5/2 correlation φ(r²) = (1 + √5 r + 5r²/3) exp(−√5 r), r = √(r²).
struct Matern52Kernel {
  static constexpr std::string_view kName = "matern52";
  /// φ(r²).
  static double Value(double r2) {
    const double s = std::sqrt(5.0 * r2);
    return (1.0 + s + 5.0 / 3.0 * r2) * std::exp(-s);
  }
  /// dφ/d(r²) = −(5/6)(1 + √5 r) exp(−√5 r), finite at r = 0.
  static double DerivativeR2(double r2) {
    const double s = std::sqrt(5.0 * r2);
    return -5.0 / 6.0 * (1.0 + s) * std::exp(-s);
  }
  /// Vectorised φ and (when not null) dφ/d(r²) of a whole array of r² values.
  static void Evaluate(const Eigen::ArrayXXd& r2, Eigen::ArrayXXd* value, Eigen::ArrayXXd* derivative) {
    const Eigen::ArrayXXd s = (5.0 * r2).sqrt();
    const Eigen::ArrayXXd e = (-s).exp();
    *value = (1.0 + s + (5.0 / 3.0) * r2) * e;
    if (derivative) *derivative = (-5.0 / 6.0) * (1.0 + s) * e;
  }
};

/// Bounds and settings of the hyperparameter fit. Units: lengthscales in unit-cube widths,
/// σ_f and σ_n in standardised output units.
struct GaussianProcessOptions {
  double min_lengthscale = 0.01;   ///< > 0
  double max_lengthscale = 20.0;   ///< > min_lengthscale
  double min_signal_std = 0.05;    ///< > 0
  double max_signal_std = 20.0;    ///< > min_signal_std
  double min_noise_std = 1e-4;     ///< > 0 (also the jitter that keeps Σ positive definite)
  double max_noise_std = 2.0;      ///< >= min_noise_std
  bool learn_noise = true;         ///< false: σ_n stays at initial_noise_std
  double initial_lengthscale = 0.3;   ///< start of the first fit, in [min, max]_lengthscale
  double initial_noise_std = 1e-2;    ///< in [min_noise_std, max_noise_std]
  int fit_iterations = 60;         ///< L-BFGS iterations per start, >= 1

  /// Throws ConfigError(file, prefix + key, ...) for a value outside its range (GpFields())
  /// or bounds that cross (max <= min, an initial value outside its bounds). The default
  /// prefix is the options' key in a `bo:` map.
  void Validate(const std::string& file = "", const std::string& prefix = "gp.") const;

  friend bool operator==(const GaussianProcessOptions&, const GaussianProcessOptions&) = default;
};

/// The keys of a `gp:` map (inside `bo:`).
const Fields<GaussianProcessOptions>& GpFields();

/// Hyperparameters in log space.
struct GpHyperparameters {
  Eigen::VectorXd log_lengthscales;  ///< ln ℓ_k, k = 1..d
  double log_signal_std = 0.0;       ///< ln σ_f
  double log_noise_std = -4.6;       ///< ln σ_n
};

/// Outcome of a hyperparameter fit.
struct GpFitSummary {
  double log_marginal_likelihood = 0.0;  ///< at the chosen hyperparameters
  int starts = 0;                        ///< local fits run
  int evaluations = 0;                   ///< likelihood + gradient evaluations
};

/// Gaussian-process regression with an ARD kernel chosen at compile time.
template <class Kernel>
class GaussianProcess {
 public:
  /// A process over [0, 1]^dim (dim >= 1) with no data. Validates `options`.
  explicit GaussianProcess(int dim, GaussianProcessOptions options = {});

  /// Replaces the data: rows of `inputs` (n × d, unit cube), `targets` (objective units),
  /// `noise_variances` v_j (objective units², >= 0) and `noise_multipliers` m_j (>= 1; empty →
  /// all 1). Recomputes the output scaling and the Cholesky factor. Throws
  /// std::invalid_argument on wrong sizes or non-finite values.
  void SetData(const Eigen::MatrixXd& inputs, const Eigen::VectorXd& targets,
               const Eigen::VectorXd& noise_variances, const Eigen::VectorXd& noise_multipliers = {});
  /// Adds one observation with the output scaling kept fixed; O(n²) rank-append of L.
  void Append(const Eigen::VectorXd& input, double target, double noise_variance = 0.0,
              double noise_multiplier = 1.0);
  /// Keeps the first n observations (n <= Size()); L's leading block stays valid.
  void Truncate(int n);

  /// Maximises the log marginal likelihood over the current data from the current
  /// hyperparameters (warm start) plus `random_restarts` random starts drawn from `rng`,
  /// keeps the best and refactorises. Needs Size() >= 1.
  GpFitSummary Fit(Rng& rng, int random_restarts);
  /// Sets the hyperparameters (clamped into the option bounds) and refactorises.
  void SetHyperparameters(const GpHyperparameters& hyper);
  /// The current hyperparameters.
  [[nodiscard]] const GpHyperparameters& Hyperparameters() const { return hyper_; }

  /// Log marginal likelihood of the current data at packed log-parameters p = (ln ℓ, ln σ_f,
  /// ln σ_n); writes its gradient into `gradient` when not null. Does not change the process.
  [[nodiscard]] double LogMarginalLikelihood(const Eigen::VectorXd& p, Eigen::VectorXd* gradient) const;
  /// Packs the current hyperparameters into p.
  [[nodiscard]] Eigen::VectorXd PackedHyperparameters() const;

  /// Posterior of the latent function at u (unit cube), in objective units: mean and variance.
  void Predict(const Eigen::VectorXd& u, double* mean, double* variance) const;
  /// Posterior in standardised units with gradients with respect to u (either may be null).
  void PredictStandardized(const Eigen::VectorXd& u, double* mean, double* variance,
                           Eigen::VectorXd* mean_gradient, Eigen::VectorXd* variance_gradient) const;
  /// Posterior of many points (columns of `points`, d × M), standardised units. Also returns
  /// V = L⁻¹ K(data, points) (Size() × M) for ExtendPool.
  void PredictPool(const Eigen::MatrixXd& points, Eigen::MatrixXd* v, Eigen::VectorXd* mean,
                   Eigen::VectorXd* variance) const;
  /// Updates a pool prediction made with fewer observations to the current ones (after Append):
  /// adds the rows of V for the new observations and updates mean and variance in O(n M) each.
  void ExtendPool(const Eigen::MatrixXd& points, Eigen::MatrixXd* v, Eigen::VectorXd* mean,
                  Eigen::VectorXd* variance) const;

  /// Posterior means (standardised units) at the n data inputs, ỹ − diag(Σ − K) α, in O(n).
  [[nodiscard]] Eigen::VectorXd PosteriorMeanAtData() const;

  /// Number of observations.
  [[nodiscard]] int Size() const { return n_; }
  /// Input dimension d.
  [[nodiscard]] int Dim() const { return dim_; }
  /// The output scaling: ỹ = (y − OutputMean()) / OutputScale().
  [[nodiscard]] double OutputMean() const { return y_mean_; }
  [[nodiscard]] double OutputScale() const { return y_scale_; }
  /// Total noise variance of observation j in objective units², m_j (σ_n² s_y² + v_j).
  [[nodiscard]] double NoiseVariance(int j) const;
  /// Input of observation j (unit cube).
  [[nodiscard]] Eigen::VectorXd Input(int j) const { return inputs_.col(j); }
  /// The options.
  [[nodiscard]] const GaussianProcessOptions& Options() const { return options_; }
  /// Standardised-units prior variance σ_f².
  [[nodiscard]] double SignalVariance() const { return std::exp(2.0 * hyper_.log_signal_std); }

 private:
  void Refactorize();
  void Reserve(int capacity);
  void BoxBounds(Eigen::VectorXd* lower, Eigen::VectorXd* upper) const;
  [[nodiscard]] double KernelValue(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const;

  int dim_;
  GaussianProcessOptions options_;
  GpHyperparameters hyper_;
  int n_ = 0;
  Eigen::MatrixXd inputs_;      // d × capacity
  Eigen::VectorXd targets_;     // standardised, capacity
  Eigen::VectorXd noise_;       // v_j / s_y², capacity
  Eigen::VectorXd multiplier_;  // m_j, capacity
  double y_mean_ = 0.0;
  double y_scale_ = 1.0;
  Eigen::MatrixXd chol_;        // capacity × capacity, lower triangle of the leading n × n block
  Eigen::VectorXd beta_;        // L⁻¹ ỹ (capacity)
  Eigen::VectorXd alpha_;       // Σ⁻¹ ỹ (size n)
  Eigen::VectorXd inv_l2_;      // 1 / ℓ_k²
};

extern template class GaussianProcess<SquaredExponentialKernel>;
extern template class GaussianProcess<Matern52Kernel>;

}  // namespace quadtune::optimizers
