#include "quadtune/optimizers/gaussian_process.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include "../config_error_util.hpp"
#include "quadtune/common/error.hpp"

namespace quadtune::optimizers {
namespace {

using quadtune::test::ThrowsWithMessage;

struct Data {
  Eigen::MatrixXd x;
  Eigen::VectorXd y, noise, mult;
};

Data MakeData(int n, int d, std::uint64_t seed) {
  Rng rng(seed);
  Data data;
  data.x.resize(n, d);
  data.y.resize(n);
  data.noise.resize(n);
  data.mult.resize(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < d; ++j) data.x(i, j) = Uniform01(rng);
    data.y[i] = std::sin(3.0 * data.x(i, 0)) + data.x.row(i).squaredNorm() + 0.05 * StandardNormal(rng);
    data.noise[i] = 0.001 * (1 + i % 3);
    data.mult[i] = 1.0 + (i % 2);
  }
  return data;
}

template <class K>
class GaussianProcessTyped : public ::testing::Test {};
using Kernels = ::testing::Types<SquaredExponentialKernel, Matern52Kernel>;
TYPED_TEST_SUITE(GaussianProcessTyped, Kernels);

TYPED_TEST(GaussianProcessTyped, LikelihoodGradientMatchesFiniteDifferences) {
  const Data data = MakeData(15, 3, 1);
  GaussianProcess<TypeParam> gp(3);
  gp.SetData(data.x, data.y, data.noise, data.mult);
  Eigen::VectorXd p(5);
  p << std::log(0.3), std::log(0.7), std::log(1.5), std::log(1.2), std::log(0.05);
  Eigen::VectorXd g;
  const double value = gp.LogMarginalLikelihood(p, &g);
  EXPECT_TRUE(std::isfinite(value));
  for (int i = 0; i < p.size(); ++i) {
    const double h = 1e-6;
    Eigen::VectorXd a = p, b = p;
    a[i] += h;
    b[i] -= h;
    const double fd = (gp.LogMarginalLikelihood(a, nullptr) - gp.LogMarginalLikelihood(b, nullptr)) / (2 * h);
    EXPECT_NEAR(g[i], fd, 1e-5 * std::max(1.0, std::abs(fd))) << "parameter " << i;
  }
}

TYPED_TEST(GaussianProcessTyped, PredictionMatchesDenseFormula) {
  const Data data = MakeData(12, 2, 2);
  GaussianProcess<TypeParam> gp(2);
  gp.SetData(data.x, data.y, data.noise, data.mult);
  Rng rng(5);
  gp.Fit(rng, 1);
  const auto& h = gp.Hyperparameters();
  const Eigen::ArrayXd inv_l2 = (-2.0 * h.log_lengthscales).array().exp();
  const double sf2 = std::exp(2 * h.log_signal_std), sn2 = std::exp(2 * h.log_noise_std);
  const double s = gp.OutputScale(), m = gp.OutputMean();
  auto k = [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return sf2 * TypeParam::Value(((a - b).array().square() * inv_l2).sum());
  };
  const int n = 12;
  Eigen::MatrixXd kk(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) kk(i, j) = k(data.x.row(i).transpose(), data.x.row(j).transpose());
    kk(i, i) += data.mult[i] * (sn2 + data.noise[i] / (s * s));
  }
  const Eigen::VectorXd yt = (data.y.array() - m) / s;
  Eigen::VectorXd u(2);
  u << 0.3, 0.8;
  Eigen::VectorXd ku(n);
  for (int i = 0; i < n; ++i) ku[i] = k(u, data.x.row(i).transpose());
  const double mean_ref = m + s * ku.dot(kk.ldlt().solve(yt));
  const double var_ref = s * s * (sf2 - ku.dot(kk.ldlt().solve(ku)));
  double mean = 0, var = 0;
  gp.Predict(u, &mean, &var);
  EXPECT_NEAR(mean, mean_ref, 1e-8);
  EXPECT_NEAR(var, var_ref, 1e-8);
  EXPECT_NEAR(gp.NoiseVariance(3), data.mult[3] * (sn2 * s * s + data.noise[3]), 1e-12);
}

TYPED_TEST(GaussianProcessTyped, PredictionGradientMatchesFiniteDifferences) {
  const Data data = MakeData(10, 3, 3);
  GaussianProcess<TypeParam> gp(3);
  gp.SetData(data.x, data.y, data.noise);
  Eigen::VectorXd u(3);
  u << 0.2, 0.55, 0.7;
  double mu, var;
  Eigen::VectorXd dmu, dvar;
  gp.PredictStandardized(u, &mu, &var, &dmu, &dvar);
  for (int i = 0; i < 3; ++i) {
    const double h = 1e-6;
    Eigen::VectorXd a = u, b = u;
    a[i] += h;
    b[i] -= h;
    double ma, va, mb, vb;
    gp.PredictStandardized(a, &ma, &va, nullptr, nullptr);
    gp.PredictStandardized(b, &mb, &vb, nullptr, nullptr);
    EXPECT_NEAR(dmu[i], (ma - mb) / (2 * h), 1e-5);
    EXPECT_NEAR(dvar[i], (va - vb) / (2 * h), 1e-5);
  }
}

TYPED_TEST(GaussianProcessTyped, AppendEqualsRebuildAndTruncateRestores) {
  const Data data = MakeData(20, 2, 4);
  GaussianProcess<TypeParam> inc(2);
  inc.SetData(data.x.topRows(14), data.y.head(14), data.noise.head(14), data.mult.head(14));
  Eigen::VectorXd u(2);
  u << 0.41, 0.33;
  double m0, v0;
  inc.Predict(u, &m0, &v0);
  Eigen::MatrixXd pool(2, 3);
  pool << 0.1, 0.5, 0.9, 0.2, 0.6, 0.4;
  Eigen::MatrixXd vv;
  Eigen::VectorXd pm, pv;
  inc.PredictPool(pool, &vv, &pm, &pv);
  for (int i = 14; i < 20; ++i) inc.Append(data.x.row(i).transpose(), data.y[i], data.noise[i], data.mult[i]);
  inc.ExtendPool(pool, &vv, &pm, &pv);
  for (int c = 0; c < 3; ++c) {
    double m, v, ms, vs;
    inc.PredictStandardized(pool.col(c), &ms, &vs, nullptr, nullptr);
    EXPECT_NEAR(pm[c], ms, 1e-9);
    EXPECT_NEAR(pv[c], vs, 1e-9);
    inc.Predict(pool.col(c), &m, &v);
    EXPECT_TRUE(std::isfinite(m));
  }
  inc.Truncate(14);
  double m1, v1;
  inc.Predict(u, &m1, &v1);
  EXPECT_NEAR(m1, m0, 1e-10);
  EXPECT_NEAR(v1, v0, 1e-10);
  EXPECT_EQ(inc.Size(), 14);
}

TYPED_TEST(GaussianProcessTyped, AppendMatchesSetDataWithSameScaling) {
  // With targets already standardised (mean 0, sd 1), scalings coincide and append == rebuild.
  Data data = MakeData(16, 2, 6);
  const double m = data.y.mean();
  const double sd = std::sqrt((data.y.array() - m).square().sum() / 15.0);
  data.y = (data.y.array() - m) / sd;
  GaussianProcess<TypeParam> full(2), inc(2);
  full.SetData(data.x, data.y, data.noise, data.mult);
  inc.SetData(data.x.topRows(16), data.y, data.noise, data.mult);
  inc.Truncate(10);
  for (int i = 10; i < 16; ++i) inc.Append(data.x.row(i).transpose(), data.y[i], data.noise[i], data.mult[i]);
  Eigen::VectorXd u(2);
  u << 0.7, 0.1;
  double a, b, c, d;
  full.Predict(u, &a, &b);
  inc.Predict(u, &c, &d);
  EXPECT_NEAR(a, c, 1e-9);
  EXPECT_NEAR(b, d, 1e-9);
}

TYPED_TEST(GaussianProcessTyped, FitRaisesLikelihood) {
  const Data data = MakeData(25, 2, 7);
  GaussianProcess<TypeParam> gp(2);
  gp.SetData(data.x, data.y, data.noise);
  const double before = gp.LogMarginalLikelihood(gp.PackedHyperparameters(), nullptr);
  Rng rng(1);
  const GpFitSummary s = gp.Fit(rng, 2);
  EXPECT_GT(s.log_marginal_likelihood, before);
  EXPECT_NEAR(s.log_marginal_likelihood, gp.LogMarginalLikelihood(gp.PackedHyperparameters(), nullptr), 1e-9);
}

TEST(GaussianProcess, NoiseMultiplierRaisesVarianceAsTheFormulaSays) {
  // One observation: posterior variance σ² = k − k² / (k + m σ₀²) with k = σ_f² = 1.
  GaussianProcessOptions o;
  o.learn_noise = false;
  o.initial_noise_std = 1e-4;
  o.min_noise_std = 1e-4;
  const double s0 = 0.04;
  for (double m : {1.0, 2.0, 8.0}) {
    GaussianProcess<Matern52Kernel> gp(1, o);
    gp.SetData(Eigen::MatrixXd::Constant(1, 1, 0.5), Eigen::VectorXd::Constant(1, 2.0),
               Eigen::VectorXd::Constant(1, s0), Eigen::VectorXd::Constant(1, m));
    double mean, var;
    gp.Predict(Eigen::VectorXd::Constant(1, 0.5), &mean, &var);
    const double noise = m * (1e-8 + s0);
    EXPECT_NEAR(var, 1.0 - 1.0 / (1.0 + noise), 1e-12);
  }
}

TEST(GaussianProcess, RejectsBadData) {
  GaussianProcess<Matern52Kernel> gp(2);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        gp.SetData(Eigen::MatrixXd::Zero(3, 2), Eigen::VectorXd::Zero(2), Eigen::VectorXd::Zero(3));
      },
      {"sizes differ"}));
  Eigen::VectorXd y = Eigen::VectorXd::Zero(3);
  y[1] = std::nan("");
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { gp.SetData(Eigen::MatrixXd::Zero(3, 2), y, Eigen::VectorXd::Zero(3)); },
      {"non-finite or out-of-range"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { gp.Append(Eigen::VectorXd::Zero(3), 1.0); }, {"wrong size or out-of-range"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { GaussianProcess<Matern52Kernel>(0); },
                                                       {"dimension must be >= 1", "got 0"}));
}

TEST(GaussianProcess, RejectsBadOptions) {
  GaussianProcessOptions o;
  o.max_lengthscale = o.min_lengthscale / 2;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { GaussianProcess<Matern52Kernel>(2, o); },
                                                  "gp.max_lengthscale", {"must be a finite"}));
}

}  // namespace
}  // namespace quadtune::optimizers
