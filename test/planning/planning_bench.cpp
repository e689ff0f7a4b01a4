// Benchmarks of the minimum-jerk back-end on representative queries: a cylinder forest (~1.3 m
// spacing) between the start and a local goal 7.5 m away, initial path from a grid A*.
//
//   planning_bench --benchmark_filter=Solve      solve time median/p95, iterations and quality
//   planning_bench --benchmark_filter=Throughput solves per second on 1 and 2 threads
//   planning_bench --benchmark_filter=Warm       re-plans warm-started from the executing
//   trajectory planning_bench --benchmark_filter=Esdf       the queries on an Esdf, without/with
//   curvature planning_bench --benchmark_filter=Retune     PSO re-solves of a recorded query,
//   warm-started
#include <benchmark/benchmark.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <vector>

#include "forest_scene.hpp"
#include "quadtune/planning/ipopt/trajectory_optimizer.hpp"

namespace {

using quadtune::planning::PlannerParams;
using quadtune::planning::PlanResult;
using quadtune::planning::TrajectoryOptimizer;
using quadtune::planning::testing::ForestQuery;
using quadtune::planning::testing::MakeForestQuery;

constexpr unsigned kQueries = 16;

const std::vector<ForestQuery>& Queries() {
  static const std::vector<ForestQuery> queries = [] {
    std::vector<ForestQuery> q;
    for (unsigned seed = 0; seed < kQueries; ++seed) q.push_back(MakeForestQuery(seed));
    return q;
  }();
  return queries;
}

double Percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  return v[std::min(k, v.size() - 1)];
}

/// What every solve benchmark reports: wall-time and iteration percentiles, mean cost, smallest
/// clearance, success and stall (Ipopt "acceptable level") rates.
struct SolveTally {
  std::vector<double> times_ms;
  std::vector<double> iterations;
  double cost = 0.0;
  double min_clearance = 1e9;
  int successes = 0;
  int stalled = 0;

  void Add(const PlanResult& r, std::chrono::steady_clock::time_point t0,
           std::chrono::steady_clock::time_point t1) {
    times_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    iterations.push_back(r.iterations);
    cost += r.cost.total;
    min_clearance = std::min(min_clearance, r.min_clearance);
    successes += r.Ok() ? 1 : 0;
    stalled += r.solver_status == 1 ? 1 : 0;
  }
  [[nodiscard]] double Count() const { return static_cast<double>(times_ms.size()); }
  void Report(benchmark::State& state) const {
    const double n = Count();
    state.counters["median_ms"] = Percentile(times_ms, 0.5);
    state.counters["p95_ms"] = Percentile(times_ms, 0.95);
    state.counters["iters_med"] = Percentile(iterations, 0.5);
    state.counters["iters_p95"] = Percentile(iterations, 0.95);
    state.counters["cost"] = cost / n;
    state.counters["min_clear_m"] = min_clearance;
    state.counters["success"] = successes / n;
    state.counters["stalled"] = stalled / n;
  }
};

void BM_Solve(benchmark::State& state) {
  const TrajectoryOptimizer optimizer;
  PlannerParams params;
  params.n_pol = static_cast<int>(state.range(0));
  const auto& queries = Queries();
  SolveTally tally;
  std::vector<double> cpu_ms;
  double jerk = 0.0;
  double duration = 0.0;
  double iterations = 0.0;
  double units = 0.0;
  double max_speed = 0.0;
  double max_acc = 0.0;
  std::size_t k = 0;
  for (auto _ : state) {
    const ForestQuery& q = queries[k++ % queries.size()];
    timespec c0{};
    timespec c1{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c0);
    const auto t0 = std::chrono::steady_clock::now();
    const PlanResult r = optimizer.Solve(q.request, *q.field, params);
    const auto t1 = std::chrono::steady_clock::now();
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &c1);
    benchmark::DoNotOptimize(r);
    tally.Add(r, t0, t1);
    cpu_ms.push_back(1e3 * static_cast<double>(c1.tv_sec - c0.tv_sec) +
                     1e-6 * static_cast<double>(c1.tv_nsec - c0.tv_nsec));
    jerk += r.cost.jerk;
    duration += r.duration;
    iterations += r.iterations;
    units += r.compute_units;
    max_speed = std::max(max_speed, r.max_speed);
    max_acc = std::max(max_acc, r.max_acceleration);
  }
  const double n = tally.Count();
  tally.Report(state);
  state.counters["cpu_median_ms"] = Percentile(cpu_ms, 0.5);
  state.counters["cpu_p95_ms"] = Percentile(cpu_ms, 0.95);
  state.counters["iters"] = iterations / n;
  state.counters["iters_max"] = Percentile(tally.iterations, 1.0);
  state.counters["jerk"] = jerk / n;
  state.counters["dur_s"] = duration / n;
  state.counters["units"] = units / n;
  state.counters["max_v"] = max_speed;
  state.counters["max_a"] = max_acc;
}
BENCHMARK(BM_Solve)->DenseRange(3, 8)->Iterations(48)->Unit(benchmark::kMillisecond);

// An Esdf seen only through its trilinear Evaluate(): no curvature, so the collision Hessian is
// Gauss–Newton and the stagnation safeguard is armed.
class TrilinearOnly final : public quadtune::planning::DistanceField {
 public:
  explicit TrilinearOnly(const quadtune::planning::Esdf& esdf) : esdf_(esdf) {}
  double Evaluate(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W) const override {
    return esdf_.Evaluate(p_W, grad_W);
  }

 private:
  const quadtune::planning::Esdf& esdf_;
};

// The same queries on an Esdf of the forest (0.1 m voxels): arg 1 = 0 plans on its trilinear
// values alone (TrilinearOnly), arg 1 = 1 on the Esdf itself with its C² B-spline curvature.
void BM_SolveEsdf(benchmark::State& state) {
  const TrajectoryOptimizer optimizer;
  PlannerParams params;
  params.n_pol = static_cast<int>(state.range(0));
  const bool smooth = state.range(1) != 0;
  const auto& queries = Queries();
  static const std::vector<quadtune::planning::Esdf> esdfs = [] {
    std::vector<quadtune::planning::Esdf> e;
    for (const auto& q : Queries()) e.push_back(quadtune::planning::testing::ForestEsdf(q));
    return e;
  }();
  std::vector<TrilinearOnly> trilinear;
  for (const auto& e : esdfs) trilinear.emplace_back(e);
  SolveTally tally;
  std::size_t k = 0;
  for (auto _ : state) {
    const std::size_t i = k++ % queries.size();
    const quadtune::planning::DistanceField& field =
        smooth ? static_cast<const quadtune::planning::DistanceField&>(esdfs[i]) : trilinear[i];
    const auto t0 = std::chrono::steady_clock::now();
    const PlanResult r = optimizer.Solve(queries[i].request, field, params);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(r);
    tally.Add(r, t0, t1);
  }
  tally.Report(state);
}
BENCHMARK(BM_SolveEsdf)
    ->ArgsProduct({{3, 5, 8}, {0, 1}})
    ->Iterations(48)
    ->Unit(benchmark::kMillisecond);

// Re-planning: the query is solved cold once (untimed); then, as the replanner does 1 s later,
// from the state on that trajectory to the same goal with the executing trajectory as warm start.
void BM_WarmResolve(benchmark::State& state) {
  const TrajectoryOptimizer optimizer;
  PlannerParams params;
  params.n_pol = static_cast<int>(state.range(0));
  const auto& queries = Queries();
  std::vector<PlanResult> cold;
  for (const auto& q : queries) cold.push_back(optimizer.Solve(q.request, *q.field, params));
  SolveTally tally;
  std::size_t k = 0;
  for (auto _ : state) {
    const std::size_t i = k++ % queries.size();
    const auto& prev = cold[i].trajectory;
    quadtune::planning::PlanRequest request = queries[i].request;
    const double t = std::min(1.0, 0.5 * prev.Duration());
    request.p0_W = prev.Position(t);
    request.v0_W = prev.Velocity(t);
    request.a0_W = prev.Acceleration(t);
    request.initial_path_W.clear();
    for (const auto& s : prev.Sample(0.1)) {
      if (s.t >= t) request.initial_path_W.push_back(s.p_W);
    }
    request.warm_start = &prev;
    request.warm_start_time = t;
    const auto t0 = std::chrono::steady_clock::now();
    const PlanResult r = optimizer.Solve(request, *queries[i].field, params);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(r);
    tally.Add(r, t0, t1);
  }
  tally.Report(state);
}
BENCHMARK(BM_WarmResolve)->DenseRange(3, 8)->Iterations(48)->Unit(benchmark::kMillisecond);

// Short-term (PSO) evaluation: a recorded query re-solved with other θ_s (w_col 0.8, w_dyn 0.2,
// n_pol = arg), warm-started from the plan recorded in flight (default θ_s, n_pol 5; untimed).
void BM_RetuneResolve(benchmark::State& state) {
  const TrajectoryOptimizer optimizer;
  const auto& queries = Queries();
  std::vector<PlanResult> recorded;
  for (const auto& q : queries)
    recorded.push_back(optimizer.Solve(q.request, *q.field, PlannerParams{}));
  PlannerParams params;
  params.w_col = 0.8;
  params.w_dyn = 0.2;
  params.n_pol = static_cast<int>(state.range(0));
  SolveTally tally;
  std::size_t k = 0;
  for (auto _ : state) {
    const std::size_t i = k++ % queries.size();
    quadtune::planning::PlanRequest request = queries[i].request;
    request.warm_start = &recorded[i].trajectory;
    request.warm_start_time = 0.0;
    const auto t0 = std::chrono::steady_clock::now();
    const PlanResult r = optimizer.Solve(request, *queries[i].field, params);
    const auto t1 = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(r);
    tally.Add(r, t0, t1);
  }
  tally.Report(state);
}
BENCHMARK(BM_RetuneResolve)->DenseRange(3, 8)->Iterations(48)->Unit(benchmark::kMillisecond);

void BM_Throughput(benchmark::State& state) {
  const TrajectoryOptimizer optimizer;
  PlannerParams params;
  params.n_pol = 5;
  const auto& queries = Queries();
  const int threads = static_cast<int>(state.range(0));
  tbb::task_arena arena(threads);
  constexpr int kBatch = 64;
  std::vector<PlanResult> results(kBatch);
  // Warm up one Ipopt application per worker thread.
  arena.execute([&] {
    tbb::parallel_for(0, kBatch, 1, [&](int i) {
      const auto& q = queries[static_cast<std::size_t>(i) % queries.size()];
      results[static_cast<std::size_t>(i)] = optimizer.Solve(q.request, *q.field, params);
    });
  });
  for (auto _ : state) {
    arena.execute([&] {
      tbb::parallel_for(0, kBatch, 1, [&](int i) {
        const auto& q = queries[static_cast<std::size_t>(i) % queries.size()];
        results[static_cast<std::size_t>(i)] = optimizer.Solve(q.request, *q.field, params);
      });
    });
  }
  state.counters["solves_per_s"] =
      benchmark::Counter(static_cast<double>(kBatch) * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate);
  state.counters["threads"] = threads;
}
BENCHMARK(BM_Throughput)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
