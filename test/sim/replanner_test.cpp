#include "quadtune/sim/replanner.hpp"

#include <gtest/gtest.h>

#include "../config_error_util.hpp"
#include "../planning/scene_util.hpp"
#include "quadtune/planning/ipopt/stop_and_go.hpp"
#include "quadtune/planning/quintic.hpp"

namespace quadtune::sim {
namespace {

using planning::BrakingTrajectory;
using planning::LocalMap;
using planning::LocalMapOptions;
using planning::PlannerParams;
using planning::PlanningQuery;
using planning::PlanResult;
using planning::PlanStatus;
using planning::QuinticBoundaryValue;
using planning::StopAndGoAlongPath;
using planning::Trajectory;
using planning::TrajectoryOptimizer;
using planning::TrajectoryOptimizerOptions;

using quadtune::test::ThrowsWithMessage;

TEST(QuinticBoundaryValue, MeetsBothEnds) {
  const Eigen::Vector3d p0(1, 2, 3), v0(0.5, -1, 0.2), a0(0.1, 0.3, -0.2);
  const Eigen::Vector3d p1(4, 0, 2), v1(1, 1, 0), a1(0, 0.5, 0);
  const double T = 1.7;
  const Trajectory traj({T}, {QuinticBoundaryValue(p0, v0, a0, p1, v1, a1, T)});
  EXPECT_TRUE(traj.Position(0).isApprox(p0, 1e-12));
  EXPECT_TRUE(traj.Velocity(0).isApprox(v0, 1e-12));
  EXPECT_TRUE(traj.Acceleration(0).isApprox(a0, 1e-12));
  EXPECT_LT((traj.Position(T) - p1).norm(), 1e-10);
  EXPECT_LT((traj.Velocity(T) - v1).norm(), 1e-10);
  EXPECT_LT((traj.Acceleration(T) - a1).norm(), 1e-10);
}

TEST(BrakingTrajectory, StopsAheadWithBoundedDeceleration) {
  const Eigen::Vector3d p0(0, 0, 1), v0(3, 0, 0);
  const double decel = 2.4;
  const Trajectory brake = BrakingTrajectory(p0, v0, Eigen::Vector3d::Zero(), decel);
  const double T = brake.Duration();
  EXPECT_NEAR(T, 2.0 * 3.0 / decel, 1e-12);
  EXPECT_LT(brake.Velocity(T).norm(), 1e-9);
  EXPECT_LT(brake.Acceleration(T).norm(), 1e-9);
  EXPECT_GT(brake.Position(T).x(), p0.x());
  // The speed never increases and never reverses.
  double last = v0.norm();
  for (double t = 0.0; t <= T; t += 0.01) {
    const Eigen::Vector3d v = brake.Velocity(t);
    EXPECT_GE(v.x(), -1e-9);
    EXPECT_LE(v.norm(), last + 1e-9);
    last = v.norm();
    // A smooth stop peaks at 1.875 times the mean deceleration.
    EXPECT_LE(brake.Acceleration(t).norm(), 1.875 * decel + 1e-9);
  }
}

/// Flies the FSM with perfect tracking (the drone is where the reference says).
struct KinematicFlight {
  explicit KinematicFlight(const PlannerParams& params,
                           const TrajectoryOptimizerOptions& optimizer_options = {},
                           const ReplannerOptions& fsm_options = {})
      : optimizer(optimizer_options),
        replanner(optimizer, params, fsm_options),
        map(LocalMapOptions::FromPlannerParams(params), Eigen::Vector3d(3, 0, 1.2)) {}

  void Start(const Eigen::Vector3d& start, std::vector<Eigen::Vector3d> waypoints) {
    p = start;
    v.setZero();
    replanner.StartMission(std::move(waypoints), start, 0.0, 0.0);
  }
  void Step() {
    replanner.Tick(t, p, v, map);
    t += 0.01;
    const physics::TrackingReference ref = replanner.Reference(t);
    p = ref.p_W;
    v = ref.v_W;
  }

  TrajectoryOptimizer optimizer;
  Replanner replanner;
  LocalMap map;
  double t = 0.0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
};

TEST(Replanner, ReachesEveryWaypointInFreeSpace) {
  KinematicFlight f{PlannerParams{}};
  const Eigen::Vector3d start(0, 0, 1.2), goal(8, 0, 1.2);
  f.Start(start, {goal, start});
  while (!f.replanner.Done() && f.t < 40.0) f.Step();
  ASSERT_TRUE(f.replanner.Done()) << "state " << ToString(f.replanner.state());
  EXPECT_LT((f.p - start).norm(), PlannerParams{}.goal_tolerance);
  EXPECT_EQ(f.replanner.emergency_stops(), 0);
  EXPECT_GE(f.replanner.records().size(), 2u);
  for (const auto& r : f.replanner.records()) EXPECT_TRUE(r.ok) << r.message;
  // Without obstacles the mission takes about 16 m / v_des plus acceleration phases.
  EXPECT_GT(f.replanner.mission_end_time(), 16.0 / PlannerParams{}.v_des);
  EXPECT_LT(f.replanner.mission_end_time(), 30.0);
}

TEST(Replanner, ReplansPeriodically) {
  PlannerParams params;
  params.t_pl = 0.5;
  KinematicFlight f{params};
  f.Start({0, 0, 1.2}, {{20, 0, 1.2}});
  while (f.t < 4.0) f.Step();
  // One plan at start, then one every t_pl.
  EXPECT_GE(f.replanner.records().size(), 7u);
  EXPECT_LE(f.replanner.records().size(), 9u);
}

TEST(Replanner, AvoidsObstaclesInTheMap) {
  KinematicFlight f{PlannerParams{}};
  const physics::ObstacleSet forest = planning::testing::SmallForest();
  const auto points = planning::testing::SurfacePoints(forest);
  f.map.Insert(Eigen::Vector3d(0, 0, 1.2), points);
  f.Start({0, 0, 1.2}, {{9, 0, 1.2}});
  double min_clearance = 1e9;
  while (!f.replanner.Done() && f.t < 40.0) {
    f.Step();
    min_clearance = std::min(min_clearance, forest.Distance(f.p));
  }
  ASSERT_TRUE(f.replanner.Done());
  EXPECT_GT(min_clearance, 0.15);
}

TEST(Replanner, EmergencyStopWhenAnObstacleAppearsInsideTheBrakingDistance) {
  PlannerParams params;
  params.v_des = 2.5;
  KinematicFlight f{params};
  f.Start({0, 0, 1.2}, {{30, 0, 1.2}});
  // Accelerate in free space until at speed.
  while (f.v.norm() < 2.0 && f.t < 10.0) f.Step();
  ASSERT_GE(f.v.norm(), 2.0);
  ASSERT_EQ(f.replanner.emergency_stops(), 0);
  // A wall appears 0.45 m ahead: stopping from 2 m/s at a_max = 3 m/s² needs 0.67 m.
  const double x_wall = f.p.x() + 0.45;
  f.map.Insert(f.p, planning::testing::WallPoints(x_wall, 8.0, 4.0));
  for (int i = 0; i < 20 && f.replanner.emergency_stops() == 0; ++i) f.Step();
  EXPECT_EQ(f.replanner.emergency_stops(), 1);
  EXPECT_EQ(f.replanner.state(), ReplanState::kEmergencyStop);
  // The braking trajectory brings the drone to rest.
  for (int i = 0; i < 300 && f.replanner.state() == ReplanState::kEmergencyStop; ++i) f.Step();
  EXPECT_LT(f.v.norm(), 1e-6);
}

TEST(Replanner, NoEmergencyStopWhenReplanningSucceeds) {
  KinematicFlight f{PlannerParams{}};
  f.Start({0, 0, 1.2}, {{30, 0, 1.2}});
  while (f.v.norm() < 1.5 && f.t < 10.0) f.Step();
  // A single pillar 4 m ahead on the path: a re-plan goes around it.
  physics::ObstacleSet pillar;
  pillar.cylinders.push_back({{f.p.x() + 4.0, 0.0}, 0.3, 0.0, 3.0});
  f.map.Insert(f.p, planning::testing::SurfacePoints(pillar));
  const double pillar_x = pillar.cylinders[0].center_W.x();
  // Closest approach over the whole flight past the pillar (not where the drone ends up).
  double min_distance = pillar.Distance(f.p);
  for (int i = 0; i < 300; ++i) {
    f.Step();
    min_distance = std::min(min_distance, pillar.Distance(f.p));
  }
  EXPECT_EQ(f.replanner.emergency_stops(), 0);
  EXPECT_GT(f.p.x(), pillar_x + 1.0) << "the drone has flown past the pillar";
  EXPECT_GT(min_distance, 0.15);
}

/// A query in a 6 × 3 × 1.5 m box at 0.1 m whose only obstacle is a vertical column of cells
/// around (1.0, 0.0); the front end's path is `path` (its first point is the start).
PlanningQuery ColumnQuery(std::vector<Eigen::Vector3d> path) {
  const Eigen::Vector3i dims(60, 30, 15);
  std::vector<std::uint8_t> occupancy(static_cast<std::size_t>(dims.prod()), 0);
  for (int z = 0; z < dims.z(); ++z) {
    occupancy[static_cast<std::size_t>(15 + dims.x() * (5 + dims.y() * z))] = 1;
  }
  PlanningQuery q;
  q.field = planning::Esdf::FromOccupancy(Eigen::Vector3d(-0.5, -0.5, 0.5), 0.1, dims, occupancy);
  q.p0_W = path.front();
  q.goal_W = path.back();
  q.initial_path_W = std::move(path);
  return q;
}

/// Distance (m) from p to the segment [a, b].
double SegmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                       const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double u = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + u * ab)).norm();
}

TEST(StopAndGoAlongPath, FliesEverySegmentFromRestToRestWithinTheLimits) {
  const std::vector<Eigen::Vector3d> path = {
      {0, 0, 1.2}, {0, 1, 1.2}, {2.5, 1, 1.2}, {3.5, 2, 1.6}};
  const PlanningQuery q = ColumnQuery(path);
  const TrajectoryOptimizer optimizer;
  const PlannerParams params;
  const double speed = 0.5;
  const PlanResult r = StopAndGoAlongPath(optimizer, q, params, speed);
  ASSERT_TRUE(r.Ok()) << r.message;
  ASSERT_EQ(r.trajectory.NumPieces(), 3);
  EXPECT_LE(r.max_speed, speed + 1e-9);
  EXPECT_LE(r.max_acceleration, params.a_max + 1e-9);
  EXPECT_GT(r.min_clearance, 0.8);  // the column is 1 m from the path's nearest segment
  // At rest at every corner, and on the corner's segments in between.
  double t0 = 0.0;
  double jerk_integral = 0.0;
  for (int i = 0; i < 3; ++i) {
    const double T = r.trajectory.PieceDuration(i);
    EXPECT_LT((r.trajectory.Position(t0 + T) - path[static_cast<std::size_t>(i) + 1]).norm(), 1e-9);
    EXPECT_LT(r.trajectory.Velocity(t0 + T).norm(), 1e-9);
    const int steps = 2000;
    for (int k = 0; k < steps; ++k) {
      const double t = t0 + T * (k + 0.5) / steps;
      EXPECT_LT(SegmentDistance(r.trajectory.Position(t), path[static_cast<std::size_t>(i)],
                                path[static_cast<std::size_t>(i) + 1]),
                1e-9);
      jerk_integral += r.trajectory.Jerk(t).squaredNorm() * T / steps;
    }
    t0 += T;
  }
  // The slower of the speed and the acceleration limit sets each piece's duration.
  EXPECT_NEAR(r.trajectory.PieceDuration(0), 1.875 * 1.0 / speed, 1e-12);
  // The midpoint sum over 2000 steps per piece is itself off by ≈1e-6 (relative).
  EXPECT_NEAR(r.cost.jerk, jerk_integral, 1e-5 * jerk_integral);
  EXPECT_EQ(r.iterations, 0);
}

TEST(StopAndGoAlongPath, FailsTheBackEndsCheckWhereThePathMeetsAnObstacle) {
  const TrajectoryOptimizer optimizer;
  const PlanResult r = StopAndGoAlongPath(optimizer, ColumnQuery({{0, 0, 1.2}, {2.5, 0, 1.2}}),
                                          PlannerParams{}, 0.5);
  EXPECT_EQ(r.status, PlanStatus::kCollision) << r.message;
  EXPECT_LT(r.min_clearance, 0.2);
  // A path without length is no plan.
  EXPECT_EQ(
      StopAndGoAlongPath(optimizer, ColumnQuery({{0, 0, 1.2}, {0, 0, 1.2}}), PlannerParams{}, 0.5)
          .status,
      PlanStatus::kInvalidInput);
}

TEST(Replanner, FliesTheFrontEndsPathStopAndGoWhenEveryAttemptFromRestFails) {
  // A back end allowed one Ipopt iteration never converges: every attempt fails.
  TrajectoryOptimizerOptions one_iteration;
  one_iteration.max_iterations = 1;
  const Eigen::Vector3d start(0, 0, 1.2), goal(5, 0, 1.2);
  KinematicFlight f{PlannerParams{}, one_iteration};
  f.Start(start, {goal});
  while (!f.replanner.Done() && f.t < 60.0) f.Step();
  ASSERT_TRUE(f.replanner.Done()) << "state " << ToString(f.replanner.state());
  int fallbacks = 0;
  for (const auto& r : f.replanner.records()) {
    EXPECT_EQ(r.failed_attempts, PlannerParams{}.max_attempts) << r.message;  // n_s still counts
    if (!r.ok) continue;
    EXPECT_TRUE(r.fallback);
    EXPECT_NE(r.message.find("stop-and-go"), std::string::npos) << r.message;
    ++fallbacks;
  }
  EXPECT_GE(fallbacks, 1);
  EXPECT_LE((f.p - goal).norm(), PlannerParams{}.goal_tolerance);

  // Without the fallback the drone never leaves the start.
  ReplannerOptions off;
  off.fallback_speed = 0.0;
  KinematicFlight g{PlannerParams{}, one_iteration, off};
  g.Start(start, {goal});
  while (g.t < 10.0) g.Step();
  EXPECT_FALSE(g.replanner.Done());
  for (const auto& r : g.replanner.records()) EXPECT_FALSE(r.ok);
  EXPECT_LT((g.p - start).norm(), 1e-9);
}

TEST(Replanner, RejectsAnEmptyMission) {
  TrajectoryOptimizer optimizer;
  Replanner replanner(optimizer, PlannerParams{});
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { replanner.StartMission({}, Eigen::Vector3d::Zero(), 0.0, 0.0); },
      {"needs a waypoint"}));
}

TEST(Replanner, InvalidOptionsNameTheKey) {
  TrajectoryOptimizer optimizer;
  ReplannerOptions options;
  options.brake_factor = 1.5;
  EXPECT_TRUE(
      ::quadtune::test::ThrowsConfigError([&] { Replanner(optimizer, PlannerParams{}, options); },
                                          "brake_factor", {"allowed: a number in (0, 1]"}));
  options = ReplannerOptions{};
  options.fallback_speed = -0.5;
  EXPECT_TRUE(
      ::quadtune::test::ThrowsConfigError([&] { Replanner(optimizer, PlannerParams{}, options); },
                                          "fallback_speed", {"allowed: a number in [0, inf)"}));
  PlannerParams bad;
  bad.t_pl = 0.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { Replanner(optimizer, bad); }, "t_pl",
                                                  {"allowed: a number in [0.05, 10]"}));
  // A clearance the distance field does not reach fails at construction, not mid-flight.
  bad = PlannerParams{};
  bad.clearance = 1.5;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { Replanner(optimizer, bad); }, "clearance",
                                                  {"must lie below", "esdf.max_distance"}));
}

}  // namespace
}  // namespace quadtune::sim
