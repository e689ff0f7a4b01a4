// Benchmarks on planning queries recorded in closed-loop flights: go-and-return (24 m out and
// back) at default parameters through CGAL forests of 1.3 m mean obstacle spacing, seeds 1-3.
// Every planning step of those flights is kept as a PlanningQuery (local map snapshot as an Esdf,
// start state, local goal, the executing trajectory); the benchmarks re-solve them the way the
// planner and the short-term evaluations do.
//
//   recorded_bench --benchmark_filter=RecordedSolve       one solve per query (SolveQuery's first
//       attempt, warm-started from the executing trajectory, as the planner solves it in flight)
//       at n_pol 3...8 and default weights: median/p95 time, iterations, solution quality
//   recorded_bench --benchmark_filter=RecordedCold        the same without the warm start
//   recorded_bench --benchmark_filter=ShortTermEvals      short-term evaluations as PSO runs them:
//       SolveQuery (all retries) with θ_s drawn from the benchmark experiment's box (w_col, w_dyn
//       log-uniform, n_pol 3..10), on 1 and 2 threads: evaluations per second
#include <benchmark/benchmark.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "quadtune/common/random.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/planning/ipopt/ipopt_backend.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/sim/flight.hpp"
#include "bench_util.hpp"

namespace {

using quadtune::planning::PlannerParams;
using quadtune::planning::PlanningQuery;
using quadtune::planning::PlanOutcome;
using quadtune::planning::PlanResult;
using quadtune::planning::TrajectoryOptimizer;

const TrajectoryOptimizer& Optimizer() {
  static const TrajectoryOptimizer optimizer;
  return optimizer;
}

/// Every planning query of three go-and-return flights at 1.3 m spacing (seeds 1-3).
const std::vector<PlanningQuery>& Recorded() {
  static const std::vector<PlanningQuery> queries = [] {
    std::vector<PlanningQuery> out;
    const quadtune::planning::IpoptBackend backend(Optimizer());
    for (std::uint64_t seed = 1; seed <= 3; ++seed) {
      (void)quadtune::planning::bench::FlyForest(seed, backend, &out);
    }
    return out;
  }();
  return queries;
}

double Percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(k, v.size() - 1)];
}

/// Times, iterations and solution quality of a set of solves.
struct Tally {
  std::vector<double> ms, iterations;
  double cost = 0.0, jerk = 0.0, min_clearance = 1e9, mean_clearance = 0.0;
  double max_v_ratio = 0.0, max_a_ratio = 0.0;
  double evaluations = 0.0, f_evaluations = 0.0, distance_queries = 0.0, variables = 0.0;
  int successes = 0;

  void Add(const PlanResult& r, double elapsed_ms, const PlannerParams& p) {
    ms.push_back(elapsed_ms);
    iterations.push_back(r.iterations);
    cost += r.cost.total;
    jerk += r.cost.jerk;
    min_clearance = std::min(min_clearance, r.min_clearance);
    mean_clearance += r.min_clearance;
    max_v_ratio = std::max(max_v_ratio, r.max_speed / p.v_des);
    max_a_ratio = std::max(max_a_ratio, r.max_acceleration / p.a_max);
    successes += r.Ok() ? 1 : 0;
    evaluations += r.function_evaluations + r.gradient_evaluations;
    f_evaluations += r.function_evaluations;
    distance_queries += static_cast<double>(r.distance_queries);
    variables += r.num_variables;
  }
  void Report(benchmark::State& state) const {
    const double n = static_cast<double>(ms.size());
    state.counters["queries"] = n;
    state.counters["median_ms"] = Percentile(ms, 0.5);
    state.counters["p95_ms"] = Percentile(ms, 0.95);
    state.counters["iters_med"] = Percentile(iterations, 0.5);
    state.counters["iters_p95"] = Percentile(iterations, 0.95);
    state.counters["success"] = successes / n;
    state.counters["cost"] = cost / n;
    state.counters["jerk"] = jerk / n;
    state.counters["min_clear_m"] = min_clearance;
    state.counters["mean_clear_m"] = mean_clearance / n;
    state.counters["max_v_ratio"] = max_v_ratio;
    state.counters["max_a_ratio"] = max_a_ratio;
    state.counters["evals"] = evaluations / n;        // Ipopt f + ∇f evaluations per solve
    state.counters["f_evals"] = f_evaluations / n;
    double it_sum = 0.0;
    for (double it : iterations) it_sum += it;
    state.counters["iters_mean"] = it_sum / n;
    state.counters["dist_queries"] = distance_queries / n;
    state.counters["variables"] = variables / n;
  }
};

// One solve per recorded query at n_pol = arg 0 (default weights); arg 1 = 1: warm start from the
// executing trajectory (as in flight), 0: cold.
void SolveEach(benchmark::State& state, bool warm) {
  const auto& queries = Recorded();
  PlannerParams params;
  params.n_pol = static_cast<int>(state.range(0));
  Tally tally;
  for (auto _ : state) {
    for (const PlanningQuery& q : queries) {
      PlannerParams p = q.params;  // θ_l and fixed parameters in force in flight
      p.n_pol = params.n_pol;
      const auto t0 = std::chrono::steady_clock::now();
      const PlanResult r = Optimizer().Solve(quadtune::planning::ToRequest(q, warm), q.field, p);
      const auto t1 = std::chrono::steady_clock::now();
      benchmark::DoNotOptimize(r);
      tally.Add(r, std::chrono::duration<double, std::milli>(t1 - t0).count(), p);
    }
  }
  tally.Report(state);
}
void BM_RecordedSolve(benchmark::State& state) { SolveEach(state, true); }
void BM_RecordedCold(benchmark::State& state) { SolveEach(state, false); }
BENCHMARK(BM_RecordedSolve)->DenseRange(3, 8)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RecordedCold)->DenseRange(3, 8)->Iterations(1)->Unit(benchmark::kMillisecond);

// Short-term evaluations: each re-solves one recorded query with a random θ_s (SolveQuery, with
// its retries), as PSO's candidates do; arg = threads.
void BM_ShortTermEvals(benchmark::State& state) {
  const auto& queries = Recorded();
  constexpr int kBatch = 512;
  const std::vector<PlannerParams> thetas =
      quadtune::planning::bench::RandomShortTermParams(queries, kBatch);
  const int threads = static_cast<int>(state.range(0));
  tbb::task_arena arena(threads);
  std::vector<PlanOutcome> results(kBatch);
  auto run_batch = [&] {
    arena.execute([&] {
      tbb::parallel_for(0, kBatch, 1, [&](int i) {
        const auto k = static_cast<std::size_t>(i);
        results[k] = quadtune::planning::SolveQuery(Optimizer(), queries[k % queries.size()],
                                                    thetas[k]);
      });
    });
  };
  run_batch();  // one Ipopt application per worker thread
  for (auto _ : state) run_batch();
  int ok = 0;
  double attempts = 0.0;
  for (const auto& r : results) {
    ok += r.Ok() ? 1 : 0;
    attempts += r.attempts;
  }
  state.counters["evals_per_s"] =
      benchmark::Counter(static_cast<double>(kBatch) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
  state.counters["threads"] = threads;
  state.counters["success"] = static_cast<double>(ok) / kBatch;
  state.counters["solves_per_eval"] = attempts / kBatch;
}
BENCHMARK(BM_ShortTermEvals)->Arg(1)->Arg(2)->MinTime(2.0)->UseRealTime()->Unit(
    benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
