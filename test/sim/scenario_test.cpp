#include "quadtune/sim/scenario.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "../config_error_util.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/planning/ipopt/ipopt_backend.hpp"
#include "quadtune/planning/ipopt/trajectory_optimizer.hpp"

namespace quadtune::sim {
namespace {

using quadtune::test::ThrowsConfigError;

physics::DroneDescription ResearchDrone() {
  return physics::LoadDroneDescription(std::string(QUADTUNE_SOURCE_DIR) +
                                       "/assets/drones/research_1kg.yaml");
}

/// A 10 m corridor of 3 m spacing (a short flight).
layout::Layout SparseCorridor(std::uint64_t seed) {
  layout::LayoutOptions options;
  options.region.min_W = Eigen::Vector2d(-1.0, -4.0);
  options.region.max_W = Eigen::Vector2d(11.0, 4.0);
  options.mission.start_W = Eigen::Vector3d(0.0, 0.0, 1.2);
  options.mission.goal_W = Eigen::Vector3d(10.0, 0.0, 1.2);
  options.spacing = 3.0;
  return layout::GenerateLayout(options, seed);
}

Scenario Corridor(std::uint64_t layout_seed, std::uint64_t seed, MissionKind kind) {
  physics::WorldOptions world;
  world.collision_response = physics::CollisionResponse::kPassThrough;
  return Scenario::OverLayout(SparseCorridor(layout_seed), kind, ResearchDrone(), world, seed);
}

TEST(MissionKind, NamesRoundTripAndUnknownNamesAreRefused) {
  for (const MissionKind kind : {MissionKind::kGoAndReturn, MissionKind::kGoTo}) {
    EXPECT_EQ(FromString<MissionKind>(ToString(kind)), kind);
  }
  EXPECT_STREQ(ToString(MissionKind::kGoAndReturn), "go_and_return");
  EXPECT_STREQ(ToString(MissionKind::kGoTo), "go_to");
  EXPECT_FALSE(FromString<MissionKind>("loop").has_value());
  EXPECT_TRUE(ThrowsConfigError(
      [] {
        (void)ReadEnum<MissionKind>(YamlMap::FromString("mission: loop", "f.yaml"), "mission",
                                    MissionKind::kGoAndReturn);
      },
      "mission", {"loop", "go_and_return", "go_to"}));
}

TEST(Scenario, OverLayoutTakesTheLayoutsMissionObstaclesAndTheSeed) {
  const layout::Layout corridor = SparseCorridor(4);
  physics::WorldOptions world;
  world.seed = 99;
  const Scenario there =
      Scenario::OverLayout(corridor, MissionKind::kGoTo, ResearchDrone(), world, 5);
  EXPECT_EQ(there.world.seed, 5u);
  EXPECT_EQ(there.mission.start_W, corridor.start_W());
  ASSERT_EQ(there.mission.waypoints_W.size(), 1u);
  EXPECT_EQ(there.mission.waypoints_W[0], corridor.goal_W());
  ASSERT_NE(there.obstacles, nullptr);
  EXPECT_EQ(there.obstacles->obstacles(), corridor.obstacles);

  const Scenario back = Scenario::OverLayout(corridor, MissionKind::kGoAndReturn, ResearchDrone(),
                                             world, 5, there.obstacles);
  EXPECT_EQ(back.obstacles, there.obstacles);  // the given geometry is shared, not rebuilt
  ASSERT_EQ(back.mission.waypoints_W.size(), 2u);
  EXPECT_EQ(back.mission.waypoints_W[1], corridor.start_W());
}

TEST(Scenario, OverLayoutRejectsInvalidWorldOptions) {
  physics::WorldOptions world;
  world.physics_rate_hz = -1.0;
  EXPECT_THROW(
      (void)Scenario::OverLayout(SparseCorridor(4), MissionKind::kGoTo, ResearchDrone(), world, 1),
      ConfigError);
}

TEST(MakeWorld, BuildsTheWorldAtTheStartState) {
  const Scenario s = Corridor(4, 1, MissionKind::kGoTo);
  std::shared_ptr<physics::World> world;
  physics::World& made = MakeWorld(s, world);
  ASSERT_NE(world, nullptr);
  EXPECT_EQ(&made, world.get());
  EXPECT_EQ(made.time(), 0.0);
  EXPECT_EQ(StartState(s).p_W, s.mission.start_W);
  EXPECT_LT((made.State().p_W - s.mission.start_W).norm(), 1e-6);  // Bullet holds floats
  EXPECT_LT(made.State().v_W.norm(), 1e-6);
  EXPECT_EQ(made.options().seed, 1u);
  EXPECT_EQ(made.geometry(), s.obstacles);
}

// A world re-used from another scenario (the engine's world pool) flies exactly as a fresh one.
TEST(MakeWorld, AReusedWorldFliesBitForBitAsAFreshOne) {
  const planning::TrajectoryOptimizer optimizer;
  const planning::IpoptBackend backend(optimizer);
  FlightOptions options;
  options.max_time = 30.0;
  const Scenario s = Corridor(4, 2, MissionKind::kGoTo);

  std::shared_ptr<physics::World> fresh;
  const FlightResult a =
      Fly(MakeWorld(s, fresh), s.mission, planning::PlannerParams{}, options, backend);

  std::shared_ptr<physics::World> reused;
  const Scenario other = Corridor(8, 3, MissionKind::kGoAndReturn);
  MakeWorld(other, reused);
  reused->Advance(1.0);
  physics::World* before = reused.get();
  const FlightResult b =
      Fly(MakeWorld(s, reused), s.mission, planning::PlannerParams{}, options, backend);
  EXPECT_EQ(reused.get(), before);  // Reset, not rebuilt

  ASSERT_EQ(a.metrics.status, FlightStatus::kCompleted) << a.metrics.message;
  EXPECT_EQ(a.metrics.flight_time, b.metrics.flight_time);
  EXPECT_EQ(a.metrics.plans, b.metrics.plans);
  EXPECT_EQ(a.metrics.compute_units, b.metrics.compute_units);
  ASSERT_EQ(a.log.size(), b.log.size());
  for (std::size_t i = 0; i < a.log.size(); ++i) {
    ASSERT_EQ(a.log[i].p_W, b.log[i].p_W) << "row " << i;
  }
}

}  // namespace
}  // namespace quadtune::sim
