// The EGO-Planner back end beside the Ipopt back end, on planning queries recorded in closed-loop
// flights: go-and-return (24 m out and back) at default parameters through CGAL forests of 1.3 m
// mean obstacle spacing, seeds 1-3, each back end flying its own flights (EGO queries carry an
// occupancy snapshot, Ipopt queries a distance field).
//
//   ego_bench --benchmark_filter=EgoSolve          one EgoBackend::Solve per recorded query at
//       default θ_s: median/p95 thread CPU time, success, L-BFGS runs and evaluations
//   ego_bench --benchmark_filter=ShortTermEvals    short-term evaluations on one thread, θ_s drawn
//       from the benchmark experiment's box (w_col, w_dyn log-uniform, n_pol 3..10): evaluations
//       per second, /0 Ipopt (SolveQuery), /1 EGO
//   ego_bench --benchmark_filter=ClosedLoop        one flight (seed 1) per iteration: simulated
//       seconds per thread-CPU second (real-time factor), /0 Ipopt, /1 EGO
#include <benchmark/benchmark.h>

#include <algorithm>
#include <ctime>
#include <string>
#include <vector>

#include "quadtune/common/random.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/planning/ego/ego_optimizer.hpp"
#include "quadtune/planning/ipopt/ipopt_backend.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/trajectory_backend.hpp"
#include "quadtune/sim/flight.hpp"
#include "bench_util.hpp"

namespace {

using quadtune::planning::PlannerParams;
using quadtune::planning::PlanningQuery;
using quadtune::planning::PlanOutcome;

const quadtune::planning::TrajectoryOptimizer& Optimizer() {
  static const quadtune::planning::TrajectoryOptimizer optimizer;
  return optimizer;
}
const quadtune::planning::IpoptBackend& Ipopt() {
  static const quadtune::planning::IpoptBackend backend(Optimizer());
  return backend;
}
const quadtune::planning::EgoBackend& Ego() {
  static const quadtune::planning::EgoBackend backend;
  return backend;
}
const quadtune::planning::TrajectoryBackend& Backend(int which) {
  return which == 0 ? static_cast<const quadtune::planning::TrajectoryBackend&>(Ipopt()) : Ego();
}

double ThreadCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

/// Every planning query of three flights (seeds 1-3) of back end `which` (0 Ipopt, 1 EGO).
const std::vector<PlanningQuery>& Recorded(int which) {
  static const std::vector<PlanningQuery> sets[2] = {
      [] {
        std::vector<PlanningQuery> out;
        for (std::uint64_t seed = 1; seed <= 3; ++seed) (void)quadtune::planning::bench::FlyForest(seed, Ipopt(), &out);
        return out;
      }(),
      [] {
        std::vector<PlanningQuery> out;
        for (std::uint64_t seed = 1; seed <= 3; ++seed) (void)quadtune::planning::bench::FlyForest(seed, Ego(), &out);
        return out;
      }()};
  return sets[which];
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(k, v.size() - 1)];
}

// One EgoBackend::Solve per recorded EGO query at default θ_s.
void BM_EgoSolve(benchmark::State& state) {
  const auto& queries = Recorded(1);
  std::vector<double> ms, units;
  int ok = 0;
  double runs = 0, evaluations = 0, rebounds = 0, reallocations = 0, attempts = 0;
  for (auto _ : state) {
    for (const PlanningQuery& q : queries) {
      quadtune::planning::EgoSolveStats stats;
      const double t0 = ThreadCpuSeconds();
      const auto r = quadtune::planning::SolveEgo(q, q.params, Ego().options(), 1.0, &stats);
      ms.push_back(1e3 * (ThreadCpuSeconds() - t0));
      units.push_back(r.compute_units);
      benchmark::DoNotOptimize(r);
      ok += r.Ok() ? 1 : 0;
      runs += stats.lbfgs_runs;
      evaluations += stats.evaluations;
      rebounds += stats.rebounds;
      reallocations += stats.reallocations;
      const PlanOutcome out = Ego().Solve(q, q.params, {});
      attempts += out.attempts;
    }
  }
  const double n = static_cast<double>(ms.size());
  state.counters["queries"] = n;
  state.counters["median_ms"] = Percentile(ms, 0.5);
  state.counters["p95_ms"] = Percentile(ms, 0.95);
  state.counters["units_med"] = Percentile(units, 0.5);
  state.counters["success"] = ok / n;
  state.counters["lbfgs_runs"] = runs / n;
  state.counters["evals"] = evaluations / n;
  state.counters["rebounds"] = rebounds / n;
  state.counters["reallocs"] = reallocations / n;
  state.counters["attempts"] = attempts / n;
}
BENCHMARK(BM_EgoSolve)->Iterations(1)->Unit(benchmark::kMillisecond);

// Short-term evaluations on one thread (the back end's Solve with all its attempts), random θ_s;
// arg: 0 Ipopt, 1 EGO.
void BM_ShortTermEvals(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  const auto& queries = Recorded(which);
  constexpr int kBatch = 256;
  const std::vector<PlannerParams> thetas =
      quadtune::planning::bench::RandomShortTermParams(queries, kBatch);
  const quadtune::planning::LocalPlannerOptions options;
  int ok = 0, evals = 0;
  double cpu = 0.0;
  for (auto _ : state) {
    const double t0 = ThreadCpuSeconds();
    for (int i = 0; i < kBatch; ++i) {
      const auto k = static_cast<std::size_t>(i);
      const PlanOutcome out = Backend(which).Solve(queries[k % queries.size()], thetas[k], options);
      ok += out.Ok() ? 1 : 0;
      benchmark::DoNotOptimize(out);
    }
    cpu += ThreadCpuSeconds() - t0;
    evals += kBatch;
  }
  state.counters["evals_per_cpu_s"] = evals / cpu;
  state.counters["success"] = static_cast<double>(ok) / evals;
}
BENCHMARK(BM_ShortTermEvals)->Arg(0)->Arg(1)->Iterations(2)->Unit(benchmark::kMillisecond);

// One closed-loop flight (seed 1) per iteration; arg: 0 Ipopt, 1 EGO.
void BM_ClosedLoop(benchmark::State& state) {
  const int which = static_cast<int>(state.range(0));
  double simulated = 0.0, cpu = 0.0;
  int completed = 0, flights = 0;
  for (auto _ : state) {
    const double t0 = ThreadCpuSeconds();
    const auto result = quadtune::planning::bench::FlyForest(1, Backend(which), nullptr);
    cpu += ThreadCpuSeconds() - t0;
    simulated += result.metrics.flight_time;
    completed += result.metrics.status == quadtune::sim::FlightStatus::kCompleted ? 1 : 0;
    ++flights;
  }
  state.counters["real_time_factor"] = simulated / cpu;
  state.counters["completed"] = static_cast<double>(completed) / flights;
}
BENCHMARK(BM_ClosedLoop)->Arg(0)->Arg(1)->Iterations(2)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
