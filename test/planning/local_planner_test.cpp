#include "quadtune/planning/local_planner.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "../config_error_util.hpp"
#include "quadtune/common/parallel_for.hpp"
#include "quadtune/planning/ipopt/ipopt_backend.hpp"
#include "resampled_figures.hpp"
#include "scene_util.hpp"

namespace quadtune::planning {
namespace {

/// A map of the small forest and a query from x = 0 towards x = 10.
struct ForestQuery {
  ForestQuery() : map(LocalMapOptions::FromPlannerParams(params), Eigen::Vector3d(4, 0, 1.5)) {
    map.Insert(Eigen::Vector3d(0, 0, 1.2), testing::SurfacePoints(testing::SmallForest()));
    LocalPlanner planner;
    PathSearchResult front;
    auto q = planner.MakeQuery(map, Eigen::Vector3d(0, 0, 1.2), Eigen::Vector3d(1.0, 0, 0),
                               Eigen::Vector3d::Zero(), Eigen::Vector3d(10, 0, 1.2), params,
                               nullptr, 0.0, &front);
    EXPECT_TRUE(q.has_value()) << front.message;
    if (q) query = std::move(*q);
  }
  PlannerParams params;
  LocalMap map;
  PlanningQuery query;
};

// goal_braking: a horizon goal d from the mission goal is reached at min(v_des, √(2 a_max d));
// far from the mission goal, or without the rule, at v_des.
TEST(LocalPlanner, GoalBrakingSlowsHorizonGoalsNearTheMissionGoal) {
  PlannerParams params;
  params.v_des = 5.0;
  params.h_pl = 5.0;
  LocalMap map(LocalMapOptions::FromPlannerParams(params), Eigen::Vector3d(4, 0, 1.5));
  const auto speed_at_horizon = [&](bool braking, double mission_x) {
    LocalPlannerOptions options;
    options.goal_braking = braking;
    LocalPlanner planner(options);
    const auto q = planner.MakeQuery(map, Eigen::Vector3d(0, 0, 1.2), Eigen::Vector3d::Zero(),
                                     Eigen::Vector3d::Zero(), Eigen::Vector3d(mission_x, 0, 1.2),
                                     params, nullptr, 0.0);
    EXPECT_TRUE(q.has_value());
    EXPECT_FALSE(q->goal_is_mission_goal);
    return std::pair{q->goal_v_W.norm(), (Eigen::Vector3d(mission_x, 0, 1.2) - q->goal_W).norm()};
  };
  const auto [near_speed, d] = speed_at_horizon(true, 7.0);
  EXPECT_NEAR(near_speed, std::sqrt(2.0 * params.a_max * d), 1e-9);
  EXPECT_LT(near_speed, params.v_des);
  EXPECT_NEAR(speed_at_horizon(false, 7.0).first, params.v_des, 1e-9);
  EXPECT_NEAR(speed_at_horizon(true, 40.0).first, params.v_des, 1e-9);
}

void ExpectSameOutcome(const PlanOutcome& a, const PlanOutcome& b) {
  EXPECT_EQ(a.result.status, b.result.status);
  EXPECT_EQ(a.result.trajectory, b.result.trajectory);
  EXPECT_EQ(a.result.iterations, b.result.iterations);
  EXPECT_EQ(a.result.cost.total, b.result.cost.total);
  EXPECT_EQ(a.attempts, b.attempts);
  EXPECT_EQ(a.failed_attempts, b.failed_attempts);
  EXPECT_EQ(a.compute_units, b.compute_units);
}

TEST(LocalPlanner, QueryHoldsTheWholeProblem) {
  ForestQuery f;
  const PlanningQuery& q = f.query;
  EXPECT_EQ(q.p0_W, Eigen::Vector3d(0, 0, 1.2));
  EXPECT_GE(q.initial_path_W.size(), 2u);
  EXPECT_EQ(q.initial_path_W.front(), q.p0_W);
  EXPECT_EQ(q.initial_path_W.back(), q.goal_W);
  // The local goal lies at the horizon h_pl, not at the mission goal 10 m away.
  EXPECT_FALSE(q.goal_is_mission_goal);
  EXPECT_NEAR((q.goal_W - q.p0_W).norm(), f.params.h_pl, 0.2);
  EXPECT_NEAR(q.goal_v_W.norm(), f.params.v_des, 1e-9);
  // The distance field covers the path with a margin and sees the pillars.
  for (const auto& w : q.initial_path_W) EXPECT_TRUE(q.field.Contains(w));
  // On the surface of the pillar at (3.0, 0.4), radius 0.25 m (the map holds its surface).
  EXPECT_LT(std::abs(q.field.Evaluate(Eigen::Vector3d(3.25, 0.4, 1.2), nullptr)), 0.1);
  EXPECT_GT(q.field.Evaluate(Eigen::Vector3d(1.5, 0.0, 1.2), nullptr), 0.9);
  EXPECT_GT(q.MemoryBytes(), q.field.dims().prod() * sizeof(std::int16_t));
}

TEST(LocalPlanner, SnapshotResolvedInAnotherThreadIsIdentical) {
  ForestQuery f;
  const TrajectoryOptimizer optimizer;
  const PlanOutcome here = SolveQuery(optimizer, f.query, f.params);
  ASSERT_TRUE(here.Ok()) << here.result.message;
  PlanOutcome there;
  const PlanningQuery copy = f.query;  // a copy, solved elsewhere
  std::thread worker([&] { there = SolveQuery(optimizer, copy, f.params); });
  worker.join();
  ExpectSameOutcome(here, there);
}

TEST(LocalPlanner, ConcurrentResolvesWithOtherShortTermParametersMatchSerial) {
  ForestQuery f;
  const TrajectoryOptimizer optimizer;
  std::vector<PlannerParams> thetas;
  for (int i = 0; i < 24; ++i) {
    PlannerParams p = f.params;
    p.w_col = 0.2 + 0.15 * (i % 6);
    p.w_dyn = 0.05 + 0.05 * (i % 4);
    p.n_pol = 3 + i % 5;
    thetas.push_back(p);
  }
  std::vector<PlanOutcome> serial(thetas.size());
  std::size_t serial_ok = 0;
  for (std::size_t i = 0; i < thetas.size(); ++i) {
    serial[i] = SolveQuery(optimizer, f.query, thetas[i]);
    serial_ok += serial[i].Ok() ? 1 : 0;
  }
  // Equal failures would prove little: most reference solves plan (some θ_s, e.g. w_col 0.2
  // with 3 pieces, fail the check, which must then fail alike in parallel).
  EXPECT_GE(serial_ok, thetas.size() / 2);
  for (int threads : {2, 4}) {
    std::vector<PlanOutcome> parallel(thetas.size());
    ParallelFor(threads, std::size_t{0}, thetas.size(),
                [&](std::size_t i) { parallel[i] = SolveQuery(optimizer, f.query, thetas[i]); });
    for (std::size_t i = 0; i < thetas.size(); ++i) ExpectSameOutcome(serial[i], parallel[i]);
  }
}

TEST(LocalPlanner, FrontEndFailureReturnsNoQuery) {
  PlannerParams params;
  LocalMap map(LocalMapOptions::FromPlannerParams(params), Eigen::Vector3d(0, 0, 1.5));
  // Enclose the start: walls on every side.
  std::vector<Eigen::Vector3d> box;
  for (double a = -1.0; a <= 1.0; a += 0.05) {
    for (double z = 0.0; z <= 4.0; z += 0.05) {
      box.emplace_back(1.0, a, z);
      box.emplace_back(-1.0, a, z);
      box.emplace_back(a, 1.0, z);
      box.emplace_back(a, -1.0, z);
    }
  }
  for (double x = -1.0; x <= 1.0; x += 0.05) {
    for (double y = -1.0; y <= 1.0; y += 0.05) box.emplace_back(x, y, 3.0);
  }
  map.Insert(Eigen::Vector3d(0, 0, 1.2), box);
  LocalPlanner planner;
  PathSearchResult front;
  const auto q = planner.MakeQuery(map, Eigen::Vector3d(0, 0, 1.2), Eigen::Vector3d::Zero(),
                                   Eigen::Vector3d::Zero(), Eigen::Vector3d(8, 0, 1.2), params,
                                   nullptr, 0.0, &front);
  EXPECT_FALSE(q.has_value());
  EXPECT_FALSE(front.ok());
  EXPECT_FALSE(front.message.empty());
}

TEST(LocalPlanner, FailedTrialsAreCounted) {
  ForestQuery f;
  // An impossible limit: 3 attempts, all failing, n_s = 3.
  PlannerParams impossible = f.params;
  impossible.a_max = 0.05;
  const TrajectoryOptimizer optimizer;
  const PlanOutcome out = SolveQuery(optimizer, f.query, impossible);
  EXPECT_FALSE(out.Ok());
  EXPECT_EQ(out.attempts, impossible.max_attempts);
  EXPECT_EQ(out.failed_attempts, impossible.max_attempts);
  EXPECT_GT(out.compute_units, 0.0);
}

// The collision cost is a penalty: with w_col = 0.003 every attempt's optimum cuts into the
// clearance of the forest's pillars. Weighting it 10× more after such an attempt lets the third
// attempt (w_col 0.3) keep the clearance; without that, all three fail the same way.
TEST(LocalPlanner, RetriesAfterACollisionWeightTheCollisionCostMore) {
  ForestQuery f;
  const TrajectoryOptimizer optimizer;
  PlannerParams p = f.params;
  p.w_col = 0.003;
  LocalPlannerOptions no_gain;
  no_gain.retry_collision_gain = 1.0;
  const LocalPlannerOptions gain;  // retry_collision_gain 10
  const PlanOutcome off = SolveQuery(optimizer, f.query, p, no_gain);
  EXPECT_FALSE(off.Ok());
  EXPECT_EQ(off.failed_attempts, p.max_attempts);
  EXPECT_EQ(off.result.status, PlanStatus::kCollision) << off.result.message;
  const PlanOutcome on = SolveQuery(optimizer, f.query, p, gain);
  ASSERT_TRUE(on.Ok()) << on.result.message;
  EXPECT_GE(on.failed_attempts, 1);
  // The clearance the retry kept, from the pillars themselves (not the planner's distance field):
  // the required inflation + margin, less the map's voxel (the field's discretisation).
  const double voxel = LocalMapOptions::FromPlannerParams(p).resolution;
  const double true_clearance =
      testing::Resample(on.result.trajectory, testing::SmallForest().cylinders).min_clearance;
  EXPECT_GE(true_clearance, p.inflation + optimizer.Options().collision_margin - voxel);
  // The failed attempts without the gain really cut into the clearance.
  EXPECT_LT(
      testing::Resample(off.result.trajectory, testing::SmallForest().cylinders).min_clearance,
      p.inflation + optimizer.Options().collision_margin);
  // The first attempt is the same either way (the gain applies only after a failure).
  PlannerParams one = p;
  one.max_attempts = 1;
  ExpectSameOutcome(SolveQuery(optimizer, f.query, one, no_gain),
                    SolveQuery(optimizer, f.query, one, gain));
}

TEST(LocalPlanner, RefusesAClearanceBeyondTheDistanceFieldsTruncation) {
  ForestQuery f;
  PlannerParams p = f.params;
  p.clearance = LocalPlannerOptions{}.esdf.max_distance;  // the field cannot tell 1 m from 5 m
  LocalPlanner planner;
  try {
    (void)planner.MakeQuery(f.map, Eigen::Vector3d(0, 0, 1.2), Eigen::Vector3d::Zero(),
                            Eigen::Vector3d::Zero(), Eigen::Vector3d(10, 0, 1.2), p, nullptr, 0.0,
                            nullptr);
    ADD_FAILURE() << "MakeQuery accepted clearance = max_distance";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "clearance");
    EXPECT_NE(std::string(e.what()).find("max_distance"), std::string::npos) << e.what();
  }
  // Below the truncation it plans; a longer truncation admits the larger clearance.
  p.clearance = 0.9 * LocalPlannerOptions{}.esdf.max_distance;
  EXPECT_NO_THROW(planner.options().CheckParams(p));
  LocalPlannerOptions longer;
  longer.esdf.max_distance = 2.0;
  p.clearance = 1.5;
  EXPECT_NO_THROW(longer.CheckParams(p));
  p.clearance = 2.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { longer.CheckParams(p); }, "clearance",
                                                  {"must lie below", "esdf.max_distance"}));
}

TEST(LocalPlannerOptions, BadValuesNameTheKey) {
  LocalPlannerOptions o;
  o.retry_slowdown = 0.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { o.Validate(); }, "retry_slowdown",
                                                  {"allowed: a number in (0, 1]"}));
  o = LocalPlannerOptions{};
  o.field_margin = -1.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { o.Validate(); }, "field_margin",
                                                  {"allowed: a number in [0, inf)"}));
  o = LocalPlannerOptions{};
  o.retry_collision_gain = 0.5;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { o.Validate(); }, "retry_collision_gain",
                                                  {"allowed: a number in [1, 1e+06]"}));
}

}  // namespace
}  // namespace quadtune::planning
