#pragma once
/// \file
/// Gaussian-process Bayesian optimisation with batches, per-observation noise, discounting of
/// outdated observations, noise that grows with age and moving damped bounds (paper Sec. III-C,
/// III-E and IV-B).
///
/// Method (all in the unit cube of the ParameterSpace, outputs standardised):
///  1. Initial design: `initial_design_size` points of a Latin hypercube (or uniform), drawn as
///     fractions of the search box and placed in the bounds current when each is issued; until
///     two results are in, further asks get uniform random points.
///  2. Model: GaussianProcess<Kernel> (gaussian_process.hpp); hyperparameters refitted every
///     `refit_every` results from a warm start, with `hyper_restarts` random restarts on every
///     `restart_period`-th refit.
///  3. Noise of observation j (objective units²):
///       σ_j² = m_j (σ₀,j² + σ_n² s_y²),  m_j = (1 + noise_growth · age_j) / λ_d^{n_d,j},
///     σ₀,j² the noise variance told with the result (or `default_noise_variance`), σ_n the
///     learned noise floor, n_d,j the number of NotifyContextChanged() calls since j was told
///     (the paper's discount σ² = σ₀² / λ_d^{n_d}, Sec. III-C "Tolerance to Noisy Observations"),
///     age_j the amount passed to AdvanceAge() since j was told (Sec. IV-B: "we gradually enlarge
///     the observation noise over time").
///  4. Acquisition: Expected Improvement over the incumbent μ* = min over observed points of the
///     posterior mean (not the noisy best value, so noise does not make EI over-greedy):
///       EI(u) = σ(u) h(z), z = (μ* − μ(u) − ξ) / σ(u), h(z) = z Φ(z) + φ(z)   (paper Eq. for
///     θ_{i+1} = argmax E[max(f⁺ − f_GP(θ), 0)]), maximised as log EI (stable far from the
///     incumbent) over a pool of uniform points plus points scattered around the incumbent, then
///     refined from the best `acquisition_starts` pool points by projected L-BFGS.
///  5. Batches: candidates still pending (issued, not told) and the batch's earlier members are
///     added as fantasies — Kriging believer (value = posterior mean) or constant liar (value =
///     the best observed value) — by O(n²) Cholesky appends, so q free worlds get q distinct
///     points that spread out.
///  6. Moving bounds (Sec. III-E): after each told result i, with θ* the current best,
///       θ_up,i+1 = λ_b θ_up,i + (1 − λ_b)(θ* + r_b),  θ_low,i+1 = λ_b θ_low,i + (1 − λ_b)(θ* − r_b),
///     in unit coordinates (r_b = half_width as a fraction of each parameter's range), clipped to
///     the original space; applied at the next Ask, one step per result told since the last one.
///
/// Thread safety: one thread at a time (the engine serialises calls); instances independent.

#include <Eigen/Core>
#include <array>
#include <deque>
#include <map>
#include <memory>
#include <variant>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/optimizers/gaussian_process.hpp"
#include "quadtune/optimizers/optimizer.hpp"

namespace quadtune::optimizers {

/// Kernel of the surrogate (each maps to a compile-time GaussianProcess<Kernel>).
enum class KernelChoice { kMatern52, kSquaredExponential };
constexpr auto EnumNames(KernelChoice) {
  return std::array{
      EnumName{KernelChoice::kMatern52, Matern52Kernel::kName.data()},
      EnumName{KernelChoice::kSquaredExponential, SquaredExponentialKernel::kName.data()}};
}
/// How the initial design is drawn.
enum class InitialDesign { kLatinHypercube, kUniform };
constexpr auto EnumNames(InitialDesign) {
  return std::array{EnumName{InitialDesign::kLatinHypercube, "latin_hypercube"},
                    EnumName{InitialDesign::kUniform, "uniform"}};
}
/// How pending and batch points are fantasised.
enum class BatchStrategy { kKrigingBeliever, kConstantLiar };
constexpr auto EnumNames(BatchStrategy) {
  return std::array{EnumName{BatchStrategy::kKrigingBeliever, "kriging_believer"},
                    EnumName{BatchStrategy::kConstantLiar, "constant_liar"}};
}

/// What the surrogate models of the values told.
enum class OutputTransform { kNone, kLog };
constexpr auto EnumNames(OutputTransform) {
  return std::array{EnumName{OutputTransform::kNone, "none"},
                    EnumName{OutputTransform::kLog, "log"}};
}

/// Moving damped bounds (paper Sec. III-E).
struct MovingBoundsOptions {
  bool enabled = false;     ///< off: the bounds stay where SetBounds put them (default: the space)
  double damping = 0.8;     ///< λ_b in (0, 1)
  double half_width = 0.1;  ///< r_b in (0, 1], a fraction of each parameter's unit range

  friend bool operator==(const MovingBoundsOptions&, const MovingBoundsOptions&) = default;
};

/// The keys of a `moving_bounds:` map.
const Fields<MovingBoundsOptions>& MovingBoundsFields();

/// Settings of BayesOpt. Defaults suit 1–8 parameters and ≤ 300 evaluations.
struct BayesOptOptions {
  KernelChoice kernel = KernelChoice::kMatern52;  ///< YAML: kernel: matern52 | squared_exponential
  int initial_design_size = 10;                   ///< >= 0 points before the model is used
  InitialDesign initial_design = InitialDesign::kLatinHypercube;  ///< latin_hypercube | uniform
  BatchStrategy batch_strategy = BatchStrategy::kKrigingBeliever; ///< kriging_believer | constant_liar
  /// kLog: the GP models log f (every value told must be > 0; noise variances are taken in log
  /// units), so one failure scored 1000 beside flights of 30 s weighs as a factor of 33, not as
  /// 970 s; Best and Ranked report exp of the posterior mean (a median estimate).
  OutputTransform transform = OutputTransform::kNone;
  double exploration = 0.0;          ///< ξ >= 0 in EI, standardised output units
  int acquisition_pool = 600;        ///< >= 10 pool points scored per batch member
  double local_pool_fraction = 0.3;  ///< [0, 1) share of the pool scattered around the incumbent
  int acquisition_starts = 2;        ///< >= 0 local refinements per batch member
  int acquisition_iterations = 15;   ///< >= 1 L-BFGS iterations per refinement
  int refit_every = 1;               ///< >= 1 results between hyperparameter refits
  int hyper_restarts = 2;            ///< >= 0 random restarts on a restart refit
  int restart_period = 5;            ///< >= 1: every restart_period-th refit (and the first) restarts
  bool fit_hyperparameters = true;   ///< false: keep gp.initial_* hyperparameters
  double default_noise_variance = 0.0;  ///< σ₀² >= 0 when Tell gives none, objective units²
  double discount = 1.0;             ///< λ_d in (0, 1]; 1 disables discounting
  double noise_growth = 0.0;         ///< >= 0, relative growth of noise per unit of age
  MovingBoundsOptions moving_bounds; ///< Sec. III-E
  GaussianProcessOptions gp;         ///< surrogate bounds and fit settings
  std::uint64_t seed = 0;            ///< explicit seed of every random choice

  /// Throws ConfigError(file, prefix + key, ...) naming the key and its range (the ranges of
  /// BayesOptFields(), then the cross-field rules of GaussianProcessOptions::Validate).
  void Validate(const std::string& file = "", const std::string& prefix = "") const;
  /// Reads the keys of BayesOptFields() (nested `moving_bounds:` and `gp:` maps; giving
  /// `moving_bounds:` turns moving bounds on unless it sets `enabled`); unknown keys and bad
  /// values throw ConfigError naming the file and key. Absent keys keep their defaults.
  static BayesOptOptions FromYaml(const YamlMap& map);

  friend bool operator==(const BayesOptOptions&, const BayesOptOptions&) = default;
};

/// The keys of a `bo:` map: reading, writing and the configuration reference.
const Fields<BayesOptOptions>& BayesOptFields();

/// Ask/tell Bayesian optimisation (minimisation). See the file comment for the method.
class BayesOpt final : public Optimizer {
 public:
  /// Throws ConfigError for an empty space or invalid options.
  BayesOpt(ParameterSpace space, BayesOptOptions options);

  [[nodiscard]] std::optional<BestPoint> Best() const override;
  /// Every distinct observed point, by posterior mean at the point (lowest first); `value` is
  /// that mean, `observed` the point's last observed value. Best() is the first of them.
  [[nodiscard]] std::vector<BestPoint> Ranked() const;
  [[nodiscard]] std::size_t NumPending() const override { return pending_.size(); }
  [[nodiscard]] std::size_t NumTold() const override { return observations_.size(); }
  [[nodiscard]] const ParameterSpace& Space() const override { return space_; }
  [[nodiscard]] nlohmann::json SaveState() const override;
  void RestoreState(const nlohmann::json& state) override;

  /// The short-term best θ_s changed (paper Sec. III-C): every observation told so far gets
  /// n_d += 1, so its noise variance is divided by λ_d once more.
  void NotifyContextChanged();
  /// Adds an observation at `x` (original coordinates, inside the space) that no Ask issued,
  /// e.g. a repeat of a point flown again elsewhere; checked as Tell checks. Returns its id.
  CandidateId Observe(const Eigen::VectorXd& x, double value,
                      std::optional<double> noise_variance = std::nullopt);
  /// Ages every observation told so far by `amount` (>= 0, the engine's unit: seconds or
  /// evaluations); noise grows by the factor (1 + noise_growth · age).
  void AdvanceAge(double amount = 1.0);
  /// Sets the search bounds (original coordinates, inside the space, lower <= upper;
  /// std::invalid_argument otherwise). Moving bounds start from here.
  void SetBounds(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper);
  /// Current search bounds in original coordinates.
  [[nodiscard]] Eigen::VectorXd BoundsLower() const { return space_.FromUnitContinuous(unit_lower_); }
  [[nodiscard]] Eigen::VectorXd BoundsUpper() const { return space_.FromUnitContinuous(unit_upper_); }
  /// Current search bounds in unit coordinates.
  [[nodiscard]] const Eigen::VectorXd& UnitBoundsLower() const { return unit_lower_; }
  [[nodiscard]] const Eigen::VectorXd& UnitBoundsUpper() const { return unit_upper_; }

  /// The noise variance the model uses for observation j (order told), objective units²:
  /// m_j σ₀,j² without the learned floor (see the file comment). std::out_of_range if j is bad.
  [[nodiscard]] double ObservationNoiseVariance(std::size_t j) const;
  /// n_d of observation j.
  [[nodiscard]] int ObservationDiscountCount(std::size_t j) const;
  /// Posterior mean and variance of the latent objective at x (original coordinates), objective
  /// units. Brings the model up to date first (refitting when due, exactly as the next Ask
  /// would, so the candidate sequence does not depend on calls of Predict).
  void Predict(const Eigen::VectorXd& x, double* mean, double* variance);
  /// Hyperparameters of the current model.
  [[nodiscard]] GpHyperparameters Hyperparameters() const;
  /// The options.
  [[nodiscard]] const BayesOptOptions& Options() const { return options_; }

  /// The surrogate: one GaussianProcess instantiation per KernelChoice.
  using Model = std::variant<GaussianProcess<Matern52Kernel>, GaussianProcess<SquaredExponentialKernel>>;

 protected:
  [[nodiscard]] bool Accepts(CandidateId id) const override { return pending_.count(id) > 0; }
  std::vector<Candidate> DoAsk(int k) override;
  void DoTell(CandidateId id, double value, double noise_variance) override;
  void DoCancel(CandidateId id) override { pending_.erase(id); }

 private:
  struct Observation {
    CandidateId id = 0;
    Eigen::VectorXd u;  // unit coordinates (snapped)
    double value = 0.0;
    double noise_variance = 0.0;  // σ₀²
    int discount_count = 0;       // n_d
    double age = 0.0;
  };
  void UpdateModel();
  void BuildModel(Model& model, bool refit);
  // Loads every observation (unit-cube input, value, noise variance and multiplier) into the GP.
  void LoadObservations(Model& model) const;
  void UpdateBounds();
  template <class Gp>
  void ProposeBatch(Gp& gp, int count, std::vector<Eigen::VectorXd>* out);
  template <class Gp>
  int IncumbentIndex(const Gp& gp, double* mean_std) const;
  [[nodiscard]] double NoiseMultiplier(const Observation& o) const;
  Candidate Issue(const Eigen::VectorXd& u);
  /// A model value back in objective units (exp under transform log).
  [[nodiscard]] double FromModel(double y) const;
  [[nodiscard]] bool IsDuplicate(const Eigen::VectorXd& u, const std::vector<Eigen::VectorXd>& batch) const;

  ParameterSpace space_;
  BayesOptOptions options_;
  Rng rng_;
  CandidateId next_id_ = 0;
  bool design_generated_ = false;
  std::deque<Eigen::VectorXd> design_queue_;
  std::vector<Observation> observations_;
  std::map<CandidateId, Eigen::VectorXd> pending_;  // unit coordinates
  Eigen::VectorXd unit_lower_, unit_upper_;
  Model model_;
  bool fitted_ = false;
  int told_since_refit_ = 0;
  int refit_count_ = 0;
  int told_since_bounds_ = 0;
  std::uint64_t data_version_ = 1;
  std::uint64_t model_version_ = 0;
  int incumbent_ = -1;             // index into observations_
  double incumbent_mean_std_ = 0;  // standardised posterior mean at the incumbent
};

}  // namespace quadtune::optimizers
