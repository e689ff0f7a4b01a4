#pragma once
/// \file
/// A model of a noisy objective with rare failures, for choosing which point races next
/// (racing.hpp): what is smooth is modelled apart from what is rare.
///
///  - Finished part: a Gaussian process (Matérn 5/2, ARD, hyperparameters fitted by maximum
///    likelihood with a learned noise level) on the values of the observations that did not fail.
///    Repeats of one point are separate observations, so the noise level is learned from them.
///  - Failure part: the probability that a flight at u fails, as a kernel-weighted Beta-Bernoulli
///    estimate with the finished part's lengthscales,
///      p(u) = (n₀ r̄ + Σ_j k(u, u_j) y_j) / (n₀ + Σ_j k(u, u_j)),
///    y_j = 1 for a failed observation, k the Matérn 5/2 correlation (1 at distance 0), r̄ the
///    prior mean and n₀ its weight in observations. With FailurePrior::kConstant, r̄ =
///    (F + ½) / (N + 1), the smoothed failure rate of all N observations (F failed), and n₀ = 1.
///    With FailurePrior::kLogistic, r̄(u) = σ(β₀ + βᵀu), a logistic regression on all
///    observations (ridge penalty ½‖β‖², intercept free, fit by Newton's method): a trend that
///    extrapolates, so a point whose own few flights were clean still inherits the failures of
///    the faster points around it; n₀ is then one of {1, 4, 16}, chosen with the kernel scale.
///    The kernel's lengthscales are the finished part's (each capped at 2) times one scale in
///    {1/32, …, 1/2, 1}, the one whose leave-one-out predictions of the failures are most
///    likely (with the logistic prior fit once to all observations).
///  - Score of a candidate u against a reference value f_ref (the incumbent's predicted value):
///      score(u) = P(Binomial(m, p(u)) <= a) · E[max(0, f_ref − f(u))],
///    the chance that the point flies the m maps a race asks without more than a failures (so a
///    race could accept it) times its expected improvement under the finished part's posterior.
///    A point that fails one flight in ten passes 12 maps 28% of the time and is ranked
///    accordingly, however fast its finished flights.
///
/// Thread safety: one thread at a time per instance; instances are independent.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/random.hpp"

#include "quadtune/optimizers/gaussian_process.hpp"

namespace quadtune::optimizers {

/// One observation: a point of the unit cube, its value, and whether it failed.
struct ChallengerObservation {
  Eigen::VectorXd u;
  double value = 0.0;
  bool failed = false;
};

/// What the model says of one point.
struct ChallengerEstimate {
  double failure_probability = 0.0;  ///< p(u)
  double mean = 0.0;                 ///< finished part's posterior mean at u
  double sd = 0.0;                   ///< its posterior standard deviation
  double pass_probability = 1.0;     ///< P(at most `failures` failures in `maps` flights)
  double improvement = 0.0;          ///< E[max(0, f_ref − f(u))]
  double score = 0.0;                ///< pass_probability · improvement
};

/// The prior mean of the failure part (see the file comment).
enum class FailurePrior {
  kConstant,  ///< the smoothed failure rate of all observations, weight 1
  kLogistic,  ///< a logistic regression on the point, weight chosen by leave-one-out
};
constexpr auto EnumNames(FailurePrior) {
  return std::array{EnumName{FailurePrior::kConstant, "constant"},
                    EnumName{FailurePrior::kLogistic, "logistic"}};
}

class ChallengerModel {
 public:
  /// A model over [0, 1]^dim (dim >= 1); `seed` drives the hyperparameter fit's restarts.
  ChallengerModel(int dim, std::uint64_t seed, GaussianProcessOptions gp = {},
                  FailurePrior prior = FailurePrior::kConstant);

  /// Fits both parts to `observations` (each u of size dim). With no finished observation the
  /// finished part is absent and every improvement is 0.
  void Fit(const std::vector<ChallengerObservation>& observations);

  /// p(u) (see the file comment); r̄ with no observation at all is ½.
  [[nodiscard]] double FailureProbability(const Eigen::VectorXd& u) const;
  /// The prior mean r̄(u) that p(u) shrinks towards.
  [[nodiscard]] double PriorFailureProbability(const Eigen::VectorXd& u) const;
  /// Posterior mean and standard deviation of the finished part at u; false when absent.
  bool PredictFinished(const Eigen::VectorXd& u, double* mean, double* sd) const;
  /// The estimate at u against `reference`, for a race of `maps` flights allowing `failures`.
  [[nodiscard]] ChallengerEstimate Estimate(const Eigen::VectorXd& u, double reference, int maps,
                                            int failures) const;

 private:
  void FitFinished(Eigen::Index finished);
  void FitLogisticPrior();
  void ChooseFailureLengthscales();
  /// p at u with inverse lengthscales inv_l, leaving observation `skip` out (none when >= size).
  [[nodiscard]] double FailureAt(const Eigen::VectorXd& u, const Eigen::VectorXd& inv_l,
                                 std::size_t skip) const;

  int dim_;
  std::uint64_t seed_;
  GaussianProcess<Matern52Kernel> gp_;
  bool have_gp_ = false;
  std::vector<ChallengerObservation> observations_;
  FailurePrior prior_;
  double failure_rate_ = 0.5;  // r̄ of kConstant
  Eigen::VectorXd logistic_;   // kLogistic: β₀ then β
  double prior_weight_ = 1.0;  // n₀
  Eigen::VectorXd failure_inv_l_;  // inverse lengthscales of the failure kernel
};

/// How ProposeChallenger searches the unit cube.
struct ProposalSearch {
  int random_points = 256;  ///< uniform points scored besides the starts
  int climbs = 8;           ///< best points (starts and random ones) climbed from
  int tries_per_step = 12;  ///< perturbations per step size of a climb
  /// A trust region: every point within `radius` of `center` in each coordinate (the whole
  /// cube when `center` is empty).
  Eigen::VectorXd center;
  double radius = 1.0;
};

/// A point the model proposes of its own.
struct Proposal {
  Eigen::VectorXd u;
  ChallengerEstimate estimate;
};

/// The point of [0, 1]^dim with the highest Estimate score that a search finds: the `starts`
/// (e.g. the incumbent and the flown points) and `search.random_points` uniform points are
/// scored, and the first start and the best `search.climbs` of them climb by Gaussian steps of standard deviation
/// 0.2, 0.1, 0.05 and 0.025 (`search.tries_per_step` each, a better score kept), then one
/// coordinate at a time over 17 values of its extent — the local search of SMAC's acquisition
/// optimiser. Every point is first mapped by `snap` (to a
/// representable point) after being clamped into `search`'s trust region; points for which `excluded` holds (raced already) are never proposed.
/// Empty when no point has a positive score.
std::optional<Proposal> ProposeChallenger(
    const ChallengerModel& model, const std::vector<Eigen::VectorXd>& starts, double reference,
    int maps, int failures, Rng& rng, const std::function<Eigen::VectorXd(Eigen::VectorXd)>& snap,
    const std::function<bool(const Eigen::VectorXd&)>& excluded, const ProposalSearch& search = {});

/// P(X <= k) for X ~ Binomial(n, p), n >= 0.
double BinomialCdf(int k, int n, double p);

/// E[max(0, reference − f)] for f ~ N(mean, sd²) (sd >= 0).
double ExpectedImprovementBelow(double reference, double mean, double sd);

}  // namespace quadtune::optimizers
