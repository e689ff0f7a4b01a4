// Ipopt's own cost per solve and per iteration in the planner's configuration
// (NewPlannerIpoptApplication: dense MA27, exact Hessian, the same allocator and timers), on a
// problem whose callbacks cost next to nothing: f(x) = Σ (x_i − 1)⁴ + 0.01 Σ x_i², unconstrained,
// dense lower-triangular Hessian, like MinJerkProblem's. Started at x_i = x0 + 0.01 i, it takes
// 8–13 Newton iterations to the planner's tol 1e-8. What is left of a planner solve after
// subtracting this is the cost function, the distance field and the post-solve checks.
//
//   ipopt_floor_bench      arg 0: variables n (7, 16, 22 = n_pol 3, 6, 8); arg 1: 100 · x0
//   NewApplication         NewPlannerIpoptApplication() alone: creating an application
//
// Counters: iterations per solve, us_per_solve (Ipopt and the trivial callbacks together) and
// us_per_iteration (the same divided by the iterations). The slope of us_per_solve over the
// iterations at one n is the per-iteration cost, its intercept the per-solve cost (building
// Ipopt's algorithm objects, reading the options).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <coin/IpSolveStatistics.hpp>
#include <coin/IpTNLP.hpp>

#include "quadtune/planning/ipopt/ipopt_application.hpp"

namespace {

using Ipopt::Index;
using Ipopt::Number;

class QuarticTnlp final : public quadtune::planning::UnconstrainedDenseTnlp {
 public:
  QuarticTnlp(int n, double x0) : UnconstrainedDenseTnlp(n), x0_(x0) {}

  bool get_starting_point(Index n, bool /*init_x*/, Number* x, bool /*init_z*/, Number* /*z_L*/,
                          Number* /*z_U*/, Index /*m*/, bool /*init_lambda*/,
                          Number* /*lambda*/) override {
    for (Index i = 0; i < n; ++i) x[i] = x0_ + 0.01 * i;
    return true;
  }
  bool eval_f(Index n, const Number* x, bool /*new_x*/, Number& f) override {
    f = 0.0;
    for (Index i = 0; i < n; ++i) {
      const double d = x[i] - 1.0;
      f += d * d * d * d + 0.01 * x[i] * x[i];
    }
    return true;
  }
  bool eval_grad_f(Index n, const Number* x, bool /*new_x*/, Number* g) override {
    for (Index i = 0; i < n; ++i) {
      const double d = x[i] - 1.0;
      g[i] = 4.0 * d * d * d + 0.02 * x[i];
    }
    return true;
  }
  bool eval_h(Index n, const Number* x, bool /*new_x*/, Number obj_factor, Index /*m*/,
              const Number* /*lambda*/, bool /*new_lambda*/, Index /*nele*/, Index* iRow,
              Index* jCol, Number* values) override {
    if (values == nullptr) {
      DenseLowerStructure(n, iRow, jCol);
      return true;
    }
    Index k = 0;
    for (Index r = 0; r < n; ++r) {
      for (Index c = 0; c <= r; ++c, ++k) {
        const double d = x[r] - 1.0;
        values[k] = r == c ? obj_factor * (12.0 * d * d + 0.02) : 0.0;
      }
    }
    return true;
  }
  void finalize_solution(Ipopt::SolverReturn /*status*/, Index /*n*/, const Number* /*x*/,
                         const Number* /*z_L*/, const Number* /*z_U*/, Index /*m*/,
                         const Number* /*g*/, const Number* /*lambda*/, Number /*obj_value*/,
                         const Ipopt::IpoptData* /*ip_data*/,
                         Ipopt::IpoptCalculatedQuantities* /*ip_cq*/) override {}

 private:
  double x0_;
};

void BM_IpoptFloor(benchmark::State& state) {
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = quadtune::planning::NewPlannerIpoptApplication();
  app->Options()->SetNumericValue("tol", 1e-8);  // the planner's tolerance
  Ipopt::SmartPtr<QuarticTnlp> problem =
      new QuarticTnlp(static_cast<int>(state.range(0)), 0.01 * static_cast<double>(state.range(1)));
  int iterations = 0;
  bool solved = true;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    const Ipopt::ApplicationReturnStatus status = app->OptimizeTNLP(problem);
    solved = solved && status == Ipopt::Solve_Succeeded;
    iterations = app->Statistics()->IterationCount();
  }
  const double elapsed_us =
      std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
  if (!solved) state.SkipWithError("Ipopt did not converge");
  state.counters["iterations"] = iterations;
  state.counters["us_per_solve"] = elapsed_us / static_cast<double>(state.iterations());
  state.counters["us_per_iteration"] =
      elapsed_us / static_cast<double>(state.iterations()) / std::max(1, iterations);
}
BENCHMARK(BM_IpoptFloor)->ArgsProduct({{7, 16, 22}, {105, 150, 300}});

// Creating and initialising one application with the planner's options (what ThreadApplication
// saves every solve but a thread's first).
void BM_NewApplication(benchmark::State& state) {
  for (auto _ : state) {
    Ipopt::SmartPtr<Ipopt::IpoptApplication> app = quadtune::planning::NewPlannerIpoptApplication();
    benchmark::DoNotOptimize(app);
  }
}
BENCHMARK(BM_NewApplication)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
