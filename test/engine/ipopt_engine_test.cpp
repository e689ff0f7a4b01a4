// The engine with the project's Ipopt planner: short closed-loop flights (8 m go-and-return at
// 3.0 m spacing) through the whole machinery.
#include <gtest/gtest.h>

#include <map>

#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "test_util.hpp"

namespace quadtune::engine {
namespace {

Experiment Tiny(const std::string& methods, int flights) {
  Experiment e = Experiment::LoadFile(std::string(QUADTUNE_SOURCE_DIR) + "/experiments/tiny.yaml");
  std::string text = e.text;
  auto replace = [&](const std::string& from, const std::string& to) {
    const auto pos = text.find(from);
    ASSERT_NE(pos, std::string::npos) << from;
    text.replace(pos, from.size(), to);
  };
  replace("methods: [bo_pso]", "methods: " + methods);
  replace("flights: 3", "flights: " + std::to_string(flights));
  return Experiment::FromString(text, "tiny.yaml",
                                std::string(QUADTUNE_SOURCE_DIR) + "/experiments");
}

// `sensor` changes only the keys it names (the rest keep the closed loop's camera), a bad value is
// refused naming the key; `goal_braking` reaches the local planner's options.
TEST(ClosedLoopOptions, SensorAndGoalBrakingKeys) {
  const std::string base = "layout: {spacing: 3.0}\n";
  const ClosedLoopOptions plain =
      ClosedLoopOptions::FromYaml(YamlMap::FromString(base, "p.yaml"), ".");
  EXPECT_FALSE(plain.flight.planner.goal_braking);
  const ClosedLoopOptions o = ClosedLoopOptions::FromYaml(
      YamlMap::FromString(base + "sensor: {horizontal_fov_deg: 120, rate_hz: 12}\n"
                                 "goal_braking: true\n",
                          "p.yaml"),
      ".");
  EXPECT_DOUBLE_EQ(o.flight.sensor.horizontal_fov_deg, 120.0);
  EXPECT_DOUBLE_EQ(o.flight.sensor.rate_hz, 12.0);
  EXPECT_EQ(o.flight.sensor.width, plain.flight.sensor.width);
  EXPECT_DOUBLE_EQ(o.flight.sensor.max_range, plain.flight.sensor.max_range);
  EXPECT_TRUE(o.flight.planner.goal_braking);
  try {
    (void)ClosedLoopOptions::FromYaml(
        YamlMap::FromString(base + "sensor: {horizontal_fov_deg: 200}\n", "p.yaml"), ".");
    ADD_FAILURE() << "a 200° camera was accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("horizontal_fov_deg"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("p.yaml"), std::string::npos) << e.what();
  }
}

TEST(IpoptEngine, PluginFliesRecordsQueriesAndResolvesThem) {
  const Experiment e = Tiny("[default]", 1);
  ASSERT_NE(e.planner.Extract<IpoptPlanner>(), nullptr);
  WorkerSlot slot;
  std::vector<Opaque> queries;
  FlightRequest req;
  req.map = e.planner.PrepareMap(e.MapSeed(0));
  req.params = e.planner.Defaults();
  req.seed = 3;
  req.on_query = [&](const Opaque& q) { queries.push_back(q); };
  const FlightRecord f = e.planner.Fly(req, slot);
  EXPECT_EQ(f.status, EvalStatus::kOk) << f.message;
  EXPECT_GT(f.flight_time, 0.0);
  ASSERT_FALSE(queries.empty());
  EXPECT_EQ(static_cast<int>(queries.size()), f.queries);
  const ResolveRecord r =
      e.planner.Resolve(queries.front(), {{"w_col", 0.5}, {"w_dyn", 0.1}, {"n_pol", 5}});
  EXPECT_EQ(r.status, EvalStatus::kOk);
  EXPECT_GT(r.compute_units, 0.0);
  // Deterministic: the same query and θ_s give the same compute units.
  EXPECT_EQ(e.planner.Resolve(queries.front(), {{"w_col", 0.5}, {"w_dyn", 0.1}, {"n_pol", 5}})
                .compute_units,
            r.compute_units);
  // The world pool slot is reused by the next flight.
  (void)e.planner.Fly(req, slot);
  EXPECT_EQ(slot.uses, 2);
}

TEST(IpoptEngine, EveryMethodRunsEndToEndAndAgreesAt1And2And8Threads) {
  std::vector<std::vector<std::string>> runs;
  for (int threads : {1, 2, 8}) {
    const std::string dir = test::TempDir("ipopt_e2e" + std::to_string(threads));
    RunOptions o;
    o.store_path = dir + "/r.sqlite";
    o.threads = threads;
    const RunSummary s = RunExperiment(Tiny("[default, random, pso, bo, bo_pso]", 3), o);
    ASSERT_EQ(s.status, RunStatus::kCompleted);
    std::map<std::string, int> longs, shorts;
    ResultStore store(o.store_path);
    for (const auto& r : store.Evaluations()) {
      if (r.kind == EvalKind::kValidation)
        continue;  // the held-out flights: counted by their own tests
      (r.kind == EvalKind::kLong ? longs : shorts)[ToString(r.method)] += 1;
      EXPECT_EQ(r.status, EvalStatus::kOk)
          << ToString(r.method) << " " << ToString(r.kind) << " " << r.message;
    }
    for (const char* m : {"default", "random", "pso", "bo", "bo_pso"}) EXPECT_EQ(longs[m], 3) << m;
    EXPECT_EQ(shorts["bo_pso"], 4 + 8);  // 4 per flight: first flight, then a round of 2
    EXPECT_EQ(store.Trials().size(), 5u);
    for (const auto& t : store.Trials()) EXPECT_EQ(t.status, TrialStatus::kDone);
    runs.push_back(test::Deterministic(o.store_path));
  }
  EXPECT_EQ(runs[0], runs[1]);
  EXPECT_EQ(runs[0], runs[2]);
}

}  // namespace
}  // namespace quadtune::engine
