// Google Benchmark timings of the optimizers module.
//   BM_BayesOptAsk8/<n>/<d>/<restart>: Ask(8) with a hyperparameter refit at n observations in d
//     dimensions (restart 0: warm start only, the usual refit; 1: warm start + 2 random restarts),
//     including the Cholesky rebuild, 8 batch members with Kriging-believer fantasies and the
//     acquisition optimisation.
//   BM_PsoUpdate/<d>: one particle update (Ask(1) + Tell) in a 20-particle swarm.
#include <benchmark/benchmark.h>

#include <cmath>

#include "quadtune/optimizers/bayes_opt.hpp"
#include "quadtune/optimizers/gaussian_process.hpp"
#include "quadtune/optimizers/pso.hpp"
#include "test_functions.hpp"

namespace qo = quadtune::optimizers;

namespace {

double Objective(const Eigen::VectorXd& x) {
  double f = 0.0;
  for (Eigen::Index i = 0; i < x.size(); ++i) f += std::sin(3.0 * x[i] + static_cast<double>(i)) + 0.5 * x[i] * x[i];
  return f;
}

qo::BayesOpt Prepared(int n, int d, bool restart) {
  qo::BayesOptOptions o;
  o.seed = 1;
  o.initial_design_size = n - 1;
  o.restart_period = restart ? 1 : 5;
  qo::BayesOpt bo(qo::testing::BoxSpace(d, 0.0, 1.0), o);
  auto c = bo.Ask(n - 1);
  std::vector<double> v;
  for (const auto& x : c) v.push_back(Objective(x.x));
  bo.Tell(c, v);
  c = bo.Ask(1);  // first fit (with restarts)
  bo.Tell(c[0].id, Objective(c[0].x));
  return bo;      // n results, model stale: the next Ask refits
}

void BM_BayesOptAsk8(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int d = static_cast<int>(state.range(1));
  const qo::BayesOpt prepared = Prepared(n, d, state.range(2) != 0);
  for (auto _ : state) {
    state.PauseTiming();
    qo::BayesOpt bo = prepared;
    state.ResumeTiming();
    auto c = bo.Ask(8);
    benchmark::DoNotOptimize(c);
  }
}
BENCHMARK(BM_BayesOptAsk8)
    ->ArgsProduct({{50, 100, 200}, {3, 6}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_GpLogLikelihoodGradient(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const int d = 6;
  quadtune::Rng rng(1);
  Eigen::MatrixXd x(n, d);
  Eigen::VectorXd y(n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < d; ++j) x(i, j) = quadtune::Uniform01(rng);
    y[i] = Objective(x.row(i).transpose());
  }
  qo::GaussianProcess<qo::Matern52Kernel> gp(d);
  gp.SetData(x, y, Eigen::VectorXd::Zero(n));
  const Eigen::VectorXd p = gp.PackedHyperparameters();
  Eigen::VectorXd g;
  for (auto _ : state) benchmark::DoNotOptimize(gp.LogMarginalLikelihood(p, &g));
}
BENCHMARK(BM_GpLogLikelihoodGradient)->Arg(50)->Arg(100)->Arg(200)->Unit(benchmark::kMicrosecond);

void BM_PsoUpdate(benchmark::State& state) {
  const int d = static_cast<int>(state.range(0));
  qo::Pso pso(qo::testing::BoxSpace(d, -5.0, 5.0), {});
  for (auto _ : state) {
    const auto c = pso.Ask(1);
    pso.Tell(c[0].id, qo::testing::Sphere(c[0].x));
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_PsoUpdate)->Arg(3)->Arg(6)->Unit(benchmark::kNanosecond);

}  // namespace

BENCHMARK_MAIN();
