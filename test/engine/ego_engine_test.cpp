// The engine with the EGO-Planner back end: the plug-in flies, records occupancy queries and
// re-solves them bit-reproducibly, and a tiny experiment file with `planner.type: ego` runs.
#include <gtest/gtest.h>

#include <thread>
#include <vector>

#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "test_util.hpp"

namespace quadtune::engine {
namespace {

Experiment TinyEgo() {
  return Experiment::LoadFile(std::string(QUADTUNE_SOURCE_DIR) + "/experiments/tiny_ego.yaml");
}

TEST(EgoEngine, PluginFliesRecordsQueriesAndResolvesThemFromManyThreads) {
  const Experiment e = TinyEgo();
  EXPECT_EQ(e.planner_type, "ego");
  ASSERT_NE(e.planner.Extract<EgoPlanner>(), nullptr);
  EXPECT_EQ(e.planner.Name(), "ego");
  WorkerSlot slot;
  std::vector<Opaque> queries;
  const FlightRecord f = test::FlyRecordingQueries(e.planner, e.MapSeed(0), slot, &queries);
  EXPECT_EQ(f.status, EvalStatus::kOk) << f.message;
  EXPECT_TRUE(f.completed) << f.message;
  EXPECT_GT(f.plans, 0);
  ASSERT_FALSE(queries.empty());
  EXPECT_EQ(static_cast<int>(queries.size()), f.queries);
  // Recorded queries carry the occupancy snapshot, not a distance field.
  EXPECT_NE(queries.front().As<planning::PlanningQuery>().occupancy, nullptr);
  const ParamValues theta{{"w_col", 0.5}, {"w_dyn", 0.1}, {"n_pol", 5}};
  std::vector<ResolveRecord> serial;
  for (const auto& q : queries) serial.push_back(e.planner.Resolve(q, theta));
  int successes = 0;
  for (const auto& r : serial) {
    EXPECT_EQ(r.status, EvalStatus::kOk);
    EXPECT_GT(r.compute_units, 0.0);
    successes += r.success ? 1 : 0;
  }
  EXPECT_GT(successes, 0);
  std::vector<std::vector<ResolveRecord>> parallel(8);
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      for (const auto& q : queries) parallel[t].push_back(e.planner.Resolve(q, theta));
    });
  }
  for (auto& th : threads) th.join();
  for (const auto& run : parallel) {
    ASSERT_EQ(run.size(), serial.size());
    for (std::size_t k = 0; k < run.size(); ++k) {
      EXPECT_EQ(run[k].success, serial[k].success);
      EXPECT_EQ(run[k].compute_units, serial[k].compute_units);
      EXPECT_EQ(run[k].duration, serial[k].duration);
      EXPECT_EQ(run[k].jerk_integral, serial[k].jerk_integral);
      EXPECT_EQ(run[k].min_clearance, serial[k].min_clearance);
    }
  }
}

TEST(EgoEngine, TinyRunCompletesAndStoresEvaluations) {
  const std::string dir = test::TempDir("ego_run");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  o.threads = 2;
  const RunSummary s = RunExperiment(TinyEgo(), o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  ResultStore store(o.store_path);
  int longs = 0, shorts = 0;
  for (const auto& r : store.Evaluations()) {
    (r.kind == EvalKind::kLong ? longs : shorts) += 1;
    EXPECT_EQ(r.status, EvalStatus::kOk) << ToString(r.kind) << " " << r.message;
  }
  EXPECT_EQ(longs, 3);
  EXPECT_GT(shorts, 0);
  ASSERT_EQ(store.Trials().size(), 1u);
  EXPECT_EQ(store.Trials().front().status, TrialStatus::kDone);
}

}  // namespace
}  // namespace quadtune::engine
