#include "quadtune/optimizers/challenger_model.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <limits>
#include <cmath>
#include <numbers>
#include <span>

#include "quadtune/common/error.hpp"
#include "quadtune/common/random.hpp"

namespace quadtune::optimizers {
namespace {

constexpr double kConstantPriorWeight = 1.0;  // n₀ of FailurePrior::kConstant
constexpr std::array kLogisticPriorWeights = {1.0, 4.0, 16.0};  // n₀ of kLogistic
constexpr double kLogisticRidge = 0.1;  // penalty ½ λ ‖β‖² of the logistic prior
constexpr int kLogisticIterations = 30;
constexpr int kFitRestarts = 2;
constexpr double kMaxShape = 2.0;  // cap of a lengthscale that shapes the failure kernel
constexpr int kCoordinateSteps = 16;  // a coordinate pass of ProposeChallenger: 17 values
constexpr std::array kFailureScales = {1.0 / 32, 1.0 / 16, 1.0 / 8, 1.0 / 4, 1.0 / 2, 1.0};

}  // namespace

double BinomialCdf(int k, int n, double p) {
  if (k < 0) return 0.0;
  if (k >= n) return 1.0;
  p = std::clamp(p, 0.0, 1.0);
  double sum = 0.0;
  for (int i = 0; i <= k; ++i) {
    const double log_choose = std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0);
    const double term_p = i == 0 ? 0.0 : i * std::log(p);
    const double term_q = n - i == 0 ? 0.0 : (n - i) * std::log1p(-p);
    sum += std::exp(log_choose + term_p + term_q);
  }
  return std::min(sum, 1.0);
}

double ExpectedImprovementBelow(double reference, double mean, double sd) {
  if (!(sd > 1e-12)) return std::max(0.0, reference - mean);
  const double z = (reference - mean) / sd;
  const double cdf = 0.5 * std::erfc(-z / std::numbers::sqrt2);
  const double pdf = std::exp(-0.5 * z * z) / std::sqrt(2.0 * std::numbers::pi);
  return std::max(0.0, sd * (z * cdf + pdf));
}

ChallengerModel::ChallengerModel(int dim, std::uint64_t seed, GaussianProcessOptions gp,
                                 FailurePrior prior)
    : dim_(dim),
      seed_(seed),
      gp_(dim, std::move(gp)),
      prior_(prior),
      failure_inv_l_(Eigen::VectorXd::Constant(dim, 1.0 / gp_.Options().initial_lengthscale)) {}

void ChallengerModel::Fit(const std::vector<ChallengerObservation>& observations) {
  observations_ = observations;
  int failed = 0;
  for (const auto& o : observations_) {
    QT_DEMAND(o.u.size() == dim_, "ChallengerModel: an observation of the wrong dimension");
    failed += o.failed ? 1 : 0;
  }
  const auto n = static_cast<double>(observations_.size());
  failure_rate_ = (failed + 0.5) / (n + 1.0);
  const auto finished = static_cast<Eigen::Index>(observations_.size()) - failed;
  have_gp_ = finished > 0;
  gp_ = GaussianProcess<Matern52Kernel>(dim_, gp_.Options());
  if (have_gp_) FitFinished(finished);
  FitLogisticPrior();
  ChooseFailureLengthscales();
}

void ChallengerModel::FitLogisticPrior() {
  logistic_.resize(0);
  if (prior_ != FailurePrior::kLogistic || observations_.empty()) return;
  // Penalised maximum likelihood by Newton's method: the objective is convex, so the iteration
  // converges from β = 0 with the intercept at the smoothed overall rate.
  const Eigen::Index n = static_cast<Eigen::Index>(observations_.size());
  Eigen::MatrixXd x(n, dim_ + 1);
  Eigen::VectorXd y(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    x(i, 0) = 1.0;
    x.row(i).tail(dim_) = observations_[static_cast<std::size_t>(i)].u.transpose();
    y[i] = observations_[static_cast<std::size_t>(i)].failed ? 1.0 : 0.0;
  }
  Eigen::VectorXd beta = Eigen::VectorXd::Zero(dim_ + 1);
  beta[0] = std::log(failure_rate_ / (1.0 - failure_rate_));
  Eigen::VectorXd ridge = Eigen::VectorXd::Constant(dim_ + 1, kLogisticRidge);
  ridge[0] = 1e-6;  // the intercept is all but free
  for (int it = 0; it < kLogisticIterations; ++it) {
    const Eigen::ArrayXd p = (1.0 / (1.0 + (-(x * beta)).array().exp()));
    const Eigen::VectorXd gradient =
        x.transpose() * (p.matrix() - y) + ridge.cwiseProduct(beta);
    const Eigen::VectorXd w = (p * (1.0 - p)).matrix();
    Eigen::MatrixXd hessian = x.transpose() * w.asDiagonal() * x;
    hessian.diagonal() += ridge;
    const Eigen::VectorXd step = hessian.ldlt().solve(gradient);
    beta -= step;
    if (step.cwiseAbs().maxCoeff() < 1e-8) break;
  }
  logistic_ = beta;
}

double ChallengerModel::PriorFailureProbability(const Eigen::VectorXd& u) const {
  if (logistic_.size() == 0) return failure_rate_;
  const double eta = logistic_[0] + logistic_.tail(dim_).dot(u);
  return 1.0 / (1.0 + std::exp(-eta));
}

void ChallengerModel::FitFinished(Eigen::Index finished) {
  Eigen::MatrixXd x(finished, dim_);
  Eigen::VectorXd y(finished);
  Eigen::Index row = 0;
  for (const auto& o : observations_) {
    if (o.failed) continue;
    x.row(row) = o.u.transpose();
    y[row++] = o.value;
  }
  // A fresh process each fit (Fit): the estimates depend on the observations only, not on the
  // sequence of earlier fits (a resumed trial refits the same observations to the same model).
  gp_.SetData(x, y, Eigen::VectorXd::Zero(finished));
  Rng rng(DeriveSeed(seed_, {static_cast<std::uint64_t>(observations_.size())}));
  (void)gp_.Fit(rng, kFitRestarts);
}

double ChallengerModel::FailureAt(const Eigen::VectorXd& u, const Eigen::VectorXd& inv_l,
                                  std::size_t skip) const {
  double weight = prior_weight_;
  double failures = prior_weight_ * PriorFailureProbability(u);
  for (std::size_t j = 0; j < observations_.size(); ++j) {
    if (j == skip) continue;
    const auto& o = observations_[j];
    const double k = Matern52Kernel::Value((u - o.u).cwiseProduct(inv_l).squaredNorm());
    weight += k;
    failures += o.failed ? k : 0.0;
  }
  return failures / weight;
}

void ChallengerModel::ChooseFailureLengthscales() {
  // The finished part's lengthscales say which directions matter (capped: beyond twice the cube
  // a direction is flat anyway); their common scale is chosen by the leave-one-out likelihood of
  // the failures, since failures change over shorter distances than flight times do.
  const Eigen::ArrayXd base = gp_.Hyperparameters().log_lengthscales.array().exp().min(kMaxShape);
  const std::span<const double> weights =
      logistic_.size() == 0 ? std::span<const double>(&kConstantPriorWeight, 1)
                            : std::span<const double>(kLogisticPriorWeights);
  double best = -std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_inv_l = failure_inv_l_;
  double best_weight = weights.front();
  for (double weight : weights) {
    prior_weight_ = weight;
    for (double scale : kFailureScales) {
      const Eigen::VectorXd inv_l = (1.0 / (scale * base)).matrix();
      double log_likelihood = 0.0;
      for (std::size_t j = 0; j < observations_.size(); ++j) {
        const double p = std::clamp(FailureAt(observations_[j].u, inv_l, j), 1e-6, 1.0 - 1e-6);
        log_likelihood += std::log(observations_[j].failed ? p : 1.0 - p);
      }
      if (log_likelihood > best) {
        best = log_likelihood;
        best_inv_l = inv_l;
        best_weight = weight;
      }
    }
  }
  failure_inv_l_ = best_inv_l;
  prior_weight_ = best_weight;
}

double ChallengerModel::FailureProbability(const Eigen::VectorXd& u) const {
  return FailureAt(u, failure_inv_l_, observations_.size());
}

bool ChallengerModel::PredictFinished(const Eigen::VectorXd& u, double* mean, double* sd) const {
  if (!have_gp_) return false;
  double variance = 0.0;
  gp_.Predict(u, mean, &variance);
  *sd = std::sqrt(std::max(variance, 0.0));
  return true;
}

ChallengerEstimate ChallengerModel::Estimate(const Eigen::VectorXd& u, double reference, int maps,
                                             int failures) const {
  ChallengerEstimate e;
  e.failure_probability = FailureProbability(u);
  e.pass_probability = BinomialCdf(failures, maps, e.failure_probability);
  if (PredictFinished(u, &e.mean, &e.sd)) {
    e.improvement = ExpectedImprovementBelow(reference, e.mean, e.sd);
  }
  e.score = e.pass_probability * e.improvement;
  return e;
}

std::optional<Proposal> ProposeChallenger(
    const ChallengerModel& model, const std::vector<Eigen::VectorXd>& starts, double reference,
    int maps, int failures, Rng& rng, const std::function<Eigen::VectorXd(Eigen::VectorXd)>& snap,
    const std::function<bool(const Eigen::VectorXd&)>& excluded, const ProposalSearch& search) {
  QT_DEMAND(!starts.empty(), "ProposeChallenger needs a start");
  const Eigen::Index dim = starts.front().size();
  std::vector<Proposal> pool;
  Eigen::VectorXd lo = Eigen::VectorXd::Zero(dim);
  Eigen::VectorXd hi = Eigen::VectorXd::Ones(dim);
  if (search.center.size() == dim) {
    lo = (search.center.array() - search.radius).max(0.0).matrix();
    hi = (search.center.array() + search.radius).min(1.0).matrix();
  }
  auto score = [&](Eigen::VectorXd u) -> std::optional<Proposal> {
    u = snap(u.cwiseMax(lo).cwiseMin(hi));
    if (excluded(u)) return std::nullopt;
    Proposal p{u, model.Estimate(u, reference, maps, failures)};
    return p;
  };
  std::optional<Proposal> first = score(starts.front());  // climbed from in any case
  for (const auto& s : starts) {
    if (auto p = score(s)) pool.push_back(std::move(*p));
  }
  for (int i = 0; i < search.random_points; ++i) {
    Eigen::VectorXd u(dim);
    for (Eigen::Index k = 0; k < dim; ++k) u[k] = Uniform(rng, lo[k], hi[k]);
    if (auto p = score(std::move(u))) pool.push_back(std::move(*p));
  }
  const auto better = [](const Proposal& a, const Proposal& b) {
    return a.estimate.score > b.estimate.score;
  };
  std::stable_sort(pool.begin(), pool.end(), better);
  pool.resize(std::min(pool.size(), static_cast<std::size_t>(search.climbs)));
  if (first) pool.push_back(std::move(*first));
  for (Proposal& climb : pool) {
    for (double step : {0.2, 0.1, 0.05, 0.025}) {
      for (int t = 0; t < search.tries_per_step; ++t) {
        Eigen::VectorXd u = climb.u;
        for (Eigen::Index k = 0; k < dim; ++k) u[k] = std::clamp(Normal(rng, u[k], step), 0.0, 1.0);
        auto p = score(std::move(u));
        if (p && better(*p, climb)) climb = std::move(*p);
      }
    }
    // One coordinate at a time over its extent (the one-exchange neighbourhood).
    for (Eigen::Index k = 0; k < dim; ++k) {
      for (int i = 0; i <= kCoordinateSteps; ++i) {
        Eigen::VectorXd u = climb.u;
        u[k] = lo[k] + (hi[k] - lo[k]) * i / kCoordinateSteps;
        auto p = score(std::move(u));
        if (p && better(*p, climb)) climb = std::move(*p);
      }
    }
  }
  std::stable_sort(pool.begin(), pool.end(), better);
  if (pool.empty() || !(pool.front().estimate.score > 0.0)) return std::nullopt;
  return pool.front();
}

}  // namespace quadtune::optimizers
