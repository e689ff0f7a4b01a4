// The two-part challenger model: its binomial and improvement formulas, its failure estimate,
// and the point it picks on a synthetic objective whose fastest points fail often.
#include "quadtune/optimizers/challenger_model.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "quadtune/common/random.hpp"

namespace quadtune::optimizers {
namespace {

TEST(ChallengerModel, BinomialCdfMatchesTheSums) {
  EXPECT_NEAR(BinomialCdf(0, 12, 0.1), std::pow(0.9, 12), 1e-12);
  EXPECT_NEAR(BinomialCdf(1, 12, 0.1), std::pow(0.9, 12) + 12 * 0.1 * std::pow(0.9, 11), 1e-12);
  EXPECT_DOUBLE_EQ(BinomialCdf(12, 12, 0.7), 1.0);
  EXPECT_DOUBLE_EQ(BinomialCdf(-1, 12, 0.1), 0.0);
  EXPECT_DOUBLE_EQ(BinomialCdf(0, 12, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(BinomialCdf(0, 12, 1.0), 0.0);
}

TEST(ChallengerModel, ExpectedImprovementOfANormal) {
  // At the reference: sd · φ(0).
  EXPECT_NEAR(ExpectedImprovementBelow(10.0, 10.0, 2.0), 2.0 / std::sqrt(2.0 * std::numbers::pi),
              1e-12);
  EXPECT_DOUBLE_EQ(ExpectedImprovementBelow(10.0, 7.0, 0.0), 3.0);
  EXPECT_DOUBLE_EQ(ExpectedImprovementBelow(10.0, 12.0, 0.0), 0.0);
  // Far below the reference the improvement is the gap.
  EXPECT_NEAR(ExpectedImprovementBelow(10.0, 0.0, 1.0), 10.0, 1e-9);
}

TEST(ChallengerModel, FailureProbabilityFollowsTheFailures) {
  std::vector<ChallengerObservation> obs;
  for (int i = 0; i < 6; ++i) {
    obs.push_back({Eigen::VectorXd::Constant(1, 0.1), 30.0 + i, false});
    obs.push_back({Eigen::VectorXd::Constant(1, 0.9), 1000.0, true});
  }
  ChallengerModel model(1, 7);
  model.Fit(obs);
  EXPECT_GT(model.FailureProbability(Eigen::VectorXd::Constant(1, 0.9)), 0.8);
  EXPECT_LT(model.FailureProbability(Eigen::VectorXd::Constant(1, 0.1)), 0.2);
  double mean = 0.0;
  double sd = 0.0;
  ASSERT_TRUE(model.PredictFinished(Eigen::VectorXd::Constant(1, 0.1), &mean, &sd));
  EXPECT_NEAR(mean, 32.5, 1.5);  // the failures' 1000 does not enter the finished part
}

/// 60 flights at uniform points of [0, 1]: a finished flight takes 30 − 15u + N(0, 2²) s, a
/// flight fails with probability q(u) = 1.25 · max(0, u − 0.6) and then scores 1000.
std::vector<ChallengerObservation> Synthetic(std::uint64_t seed) {
  Rng rng(seed);
  std::vector<ChallengerObservation> obs;
  for (int i = 0; i < 60; ++i) {
    const double u = Uniform01(rng);
    const bool failed = Uniform01(rng) < 1.25 * std::max(0.0, u - 0.6);
    obs.push_back({Eigen::VectorXd::Constant(1, u), failed ? 1000.0 : 30.0 - 15.0 * u + Normal(rng, 0.0, 2.0),
                   failed});
  }
  return obs;
}

TEST(ChallengerModel, PicksTheFastPointThatSurvivesARace) {
  // The expected gain of racing u on 12 maps without a failure, (1 − q)^12 · (15u), peaks at
  // u = 0.6 (9 s); u = 0.7 passes 20% of races, u = 0.9 0.4%. The finished part alone ranks
  // u = 1 first. Over 20 seeds the model's best point of a 0.05 grid lies in [0.45, 0.75] in at
  // least 18.
  int inside = 0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    ChallengerModel model(1, seed);
    model.Fit(Synthetic(seed));
    double reference = 0.0;
    double sd = 0.0;
    ASSERT_TRUE(model.PredictFinished(Eigen::VectorXd::Zero(1), &reference, &sd));
    double best_u = -1.0;
    double best_score = -1.0;
    double best_mean_u = -1.0;
    double best_mean = 1e9;
    for (int k = 0; k <= 20; ++k) {
      const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 0.05 * k);
      const ChallengerEstimate e = model.Estimate(u, reference, 12, 0);
      if (e.score > best_score) best_score = e.score, best_u = u[0];
      if (e.mean < best_mean) best_mean = e.mean, best_mean_u = u[0];
    }
    EXPECT_GT(best_mean_u, 0.85) << "seed " << seed;  // what ranking by the mean alone picks
    inside += best_u >= 0.45 && best_u <= 0.75 ? 1 : 0;
  }
  EXPECT_GE(inside, 18);
}

/// Synthetic() in three dimensions: the last two do not matter, the third takes 4 integer cells.
std::vector<ChallengerObservation> Synthetic3(std::uint64_t seed) {
  Rng rng(seed + 100);
  std::vector<ChallengerObservation> obs;
  for (auto& o : Synthetic(seed)) {
    Eigen::VectorXd u(3);
    u << o.u[0], Uniform01(rng), (std::floor(Uniform01(rng) * 4.0) + 0.5) / 4.0;
    obs.push_back({u, o.value, o.failed});
  }
  return obs;
}

Eigen::VectorXd SnapCells(Eigen::VectorXd u) {
  u = u.cwiseMax(0.0).cwiseMin(1.0);
  u[2] = (std::min(std::floor(u[2] * 4.0), 3.0) + 0.5) / 4.0;
  return u;
}

TEST(ChallengerModel, ProposalBeatsItsStartsInsideItsTrustRegion) {
  // The proposal scores at least as high as any start in the trust region and within 10% of the
  // best point of a grid along the first coordinate (a search, not an exact maximum), lies in
  // the trust region, has its integer coordinate on a cell
  // centre, and is never a point the caller excludes (raced already).
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    ChallengerModel model(3, seed);
    const auto obs = Synthetic3(seed);
    model.Fit(obs);
    const Eigen::Vector3d incumbent(0.2, 0.5, 0.125);
    std::vector<Eigen::VectorXd> starts{incumbent};
    for (const auto& o : obs) starts.push_back(o.u);
    double reference = 0.0;
    double sd = 0.0;
    ASSERT_TRUE(model.PredictFinished(incumbent, &reference, &sd));
    ProposalSearch search;
    search.center = incumbent;
    search.radius = 0.25;
    const auto band = [](const Eigen::VectorXd& u) { return u[0] > 0.35 && u[0] < 0.42; };
    Rng rng(seed);
    const auto p = ProposeChallenger(model, starts, reference, 12, 0, rng, SnapCells, band, search);
    ASSERT_TRUE(p.has_value());
    EXPECT_LE((p->u - incumbent).cwiseAbs().maxCoeff(), 0.25 + 1e-12) << "seed " << seed;
    EXPECT_DOUBLE_EQ(p->u[2], SnapCells(p->u)[2]);
    EXPECT_FALSE(band(p->u));
    EXPECT_DOUBLE_EQ(p->estimate.score, model.Estimate(p->u, reference, 12, 0).score);
    for (const auto& u : starts) {
      if ((u - incumbent).cwiseAbs().maxCoeff() > 0.25 || band(u)) continue;
      EXPECT_GE(p->estimate.score, model.Estimate(u, reference, 12, 0).score) << "seed " << seed;
    }
    double grid_best = 0.0;
    for (int k = 0; k <= 10; ++k) {
      Eigen::Vector3d u = incumbent;
      u[0] = 0.045 * k;  // [0, 0.45]: the trust region's extent in the first coordinate
      if (!band(u)) grid_best = std::max(grid_best, model.Estimate(u, reference, 12, 0).score);
    }
    EXPECT_GE(p->estimate.score, 0.9 * grid_best) << "seed " << seed;
  }
}

TEST(ChallengerModel, SameSeedSameProposal) {
  ChallengerModel model(3, 4);
  const auto obs = Synthetic3(4);
  model.Fit(obs);
  std::vector<Eigen::VectorXd> starts;
  for (const auto& o : obs) starts.push_back(o.u);
  const auto none = [](const Eigen::VectorXd&) { return false; };
  Rng a(11);
  Rng b(11);
  const auto pa = ProposeChallenger(model, starts, 30.0, 12, 0, a, SnapCells, none);
  const auto pb = ProposeChallenger(model, starts, 30.0, 12, 0, b, SnapCells, none);
  ASSERT_TRUE(pa && pb);
  EXPECT_EQ(pa->u, pb->u);
}

TEST(ChallengerModel, SameObservationsSameEstimates) {
  ChallengerModel a(1, 3);
  ChallengerModel b(1, 3);
  a.Fit(Synthetic(5));
  b.Fit(Synthetic(9));
  b.Fit(Synthetic(5));  // a refit depends on the observations only
  const Eigen::VectorXd u = Eigen::VectorXd::Constant(1, 0.4);
  EXPECT_EQ(a.Estimate(u, 30.0, 12, 0).score, b.Estimate(u, 30.0, 12, 0).score);
}

/// 60 flights at uniform points of [0, 0.7] × [0, 1] failing with probability q(u) = 0.5 u₀ (the
/// second coordinate does not matter): the trial has not yet flown the fastest part of the box.
std::vector<ChallengerObservation> SlowHalf(std::uint64_t seed) {
  Rng rng(seed + 300);
  std::vector<ChallengerObservation> obs;
  for (int i = 0; i < 60; ++i) {
    Eigen::VectorXd u(2);
    u << 0.7 * Uniform01(rng), Uniform01(rng);
    const bool failed = Uniform01(rng) < 0.5 * u[0];
    obs.push_back({u, failed ? 1000.0 : 30.0 - 15.0 * u[0] + Normal(rng, 0.0, 2.0), failed});
  }
  return obs;
}

TEST(ChallengerModel, LogisticPriorExtrapolatesTheFailureTrend) {
  // At u = (0.95, 0.5), beyond every flight, q = 0.475; the constant prior says the trial's
  // overall rate (about 0.17), the logistic one carries the trend in u₀ on. Over 20 seeds the
  // logistic estimate there is higher in at least 18 and its mean error at most two thirds of
  // the constant prior's; at u = (0.05, 0.5), inside the flights, both are near q = 0.025.
  const Eigen::Vector2d beyond(0.95, 0.5);
  int higher = 0;
  double error_constant = 0.0;
  double error_logistic = 0.0;
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const auto obs = SlowHalf(seed);
    ChallengerModel constant(2, seed);
    ChallengerModel logistic(2, seed, {}, FailurePrior::kLogistic);
    constant.Fit(obs);
    logistic.Fit(obs);
    const double pc = constant.FailureProbability(beyond);
    const double pl = logistic.FailureProbability(beyond);
    higher += pl > pc ? 1 : 0;
    error_constant += std::abs(pc - 0.475);
    error_logistic += std::abs(pl - 0.475);
    EXPECT_LT(logistic.FailureProbability(Eigen::Vector2d(0.05, 0.5)), 0.15) << "seed " << seed;
    // The constant prior is the overall rate, everywhere.
    EXPECT_DOUBLE_EQ(constant.PriorFailureProbability(beyond),
                     constant.PriorFailureProbability(Eigen::Vector2d(0.05, 0.5)));
  }
  EXPECT_GE(higher, 18);
  EXPECT_LE(error_logistic, error_constant * 2.0 / 3.0)
      << "mean errors " << error_logistic / 20 << " against " << error_constant / 20;
}

}  // namespace
}  // namespace quadtune::optimizers
