#include "quadtune/planning/ego/ego_optimizer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <thread>
#include <vector>

#include "scene_util.hpp"

namespace quadtune::planning {
namespace {

/// One pillar of radius 0.3 m at (3, 0) and a query from rest at (0, 0, 1.2) to (6, 0, 1.2).
struct PillarScene {
  PillarScene() : map(LocalMapOptions::FromPlannerParams(params), Eigen::Vector3d(3, 0, 1.5)) {
    pillars.cylinders.push_back({{3.0, 0.0}, 0.3, 0.0, 3.0});
    map.Insert(Eigen::Vector3d(0, 0, 1.2), testing::SurfacePoints(pillars));
  }
  PlanningQuery Query(const Eigen::Vector3d& start, const Eigen::Vector3d& v0,
                      const Eigen::Vector3d& goal) {
    LocalPlannerOptions options;
    options.snapshot = QuerySnapshot::kOccupancy;
    LocalPlanner planner(options);
    PathSearchResult front;
    auto q = planner.MakeQuery(map, start, v0, Eigen::Vector3d::Zero(), goal, params, nullptr, 0.0,
                               &front);
    EXPECT_TRUE(q.has_value()) << front.message;
    return q ? *q : PlanningQuery{};
  }
  PlannerParams params;
  physics::ObstacleSet pillars;
  LocalMap map;
};

TEST(EgoBspline, BoundaryControlPointsGiveTheBoundaryState) {
  const double dt = 0.25;
  const Eigen::Vector3d p0(1, 2, 3), v0(0.5, -1, 0.2), a0(1, 0.5, -2);
  const Eigen::Vector3d p1(4, 1, 2), v1(-1, 0.3, 0), a1(0.2, 0, 1);
  ControlPoints q(3, 9);
  q.leftCols<3>() = BoundaryControlPoints(p0, v0, a0, dt);
  q.col(3) = Eigen::Vector3d(2, 2, 2);
  q.col(4) = Eigen::Vector3d(3, 1, 3);
  q.col(5) = Eigen::Vector3d(3.5, 1, 2);
  q.rightCols<3>() = BoundaryControlPoints(p1, v1, a1, dt);
  const Trajectory t = BsplineToTrajectory(q, dt);
  ASSERT_EQ(t.NumPieces(), 6);
  EXPECT_NEAR(t.Duration(), 6 * dt, 1e-12);
  EXPECT_LT((t.Position(0) - p0).norm(), 1e-12);
  EXPECT_LT((t.Velocity(0) - v0).norm(), 1e-12);
  EXPECT_LT((t.Acceleration(0) - a0).norm(), 1e-12);
  EXPECT_LT((t.Position(t.Duration()) - p1).norm(), 1e-12);
  EXPECT_LT((t.Velocity(t.Duration()) - v1).norm(), 1e-12);
  EXPECT_LT((t.Acceleration(t.Duration()) - a1).norm(), 1e-12);
  // C² across a joint: both sides of knot 2 agree.
  for (int order = 0; order <= 2; ++order) {
    const Eigen::Vector3d left = t.Evaluate(2 * dt - 1e-9, order);
    const Eigen::Vector3d right = t.Evaluate(2 * dt, order);
    EXPECT_LT((left - right).norm(), 1e-6) << "order " << order;
  }
}

TEST(EgoRepulsion, PairsPointFromTheObstacleTowardsTheFreePath) {
  PillarScene s;
  // A straight control polygon through the pillar at y = 0.
  ControlPoints q(3, 19);
  for (int i = 0; i < 19; ++i) q.col(i) = Eigen::Vector3d(0.35 * i, 0.0, 1.2);
  std::vector<bool> colliding(19, false);
  int flagged = 0;
  for (int i = 3; i < 16; ++i) {
    colliding[i] = s.map.IsOccupied(Eigen::Vector3d(q.col(i)));
    flagged += colliding[i] ? 1 : 0;
  }
  ASSERT_GE(flagged, 2);
  PathSearcher searcher;
  long expansions = 0;
  const auto pairs = MakeRepulsionPairs(s.map, q, colliding, searcher, &expansions);
  EXPECT_GT(expansions, 0);
  ASSERT_EQ(static_cast<int>(pairs.size()), flagged);
  const double step = 0.5 * s.map.resolution();
  for (const auto& pr : pairs) {
    ASSERT_TRUE(colliding[pr.index]);
    EXPECT_NEAR(pr.v.norm(), 1.0, 1e-12);
    // Sideways (the way round the pillar), not along the polygon.
    EXPECT_LT(std::abs(pr.v.x()), 0.2) << pr.index;
    EXPECT_GT(std::abs(pr.v.y()), 0.9) << pr.index;
    // p is the first free point on the far side of the obstacle surface.
    EXPECT_FALSE(s.map.IsOccupied(pr.p));
    EXPECT_TRUE(s.map.IsOccupied(Eigen::Vector3d(pr.p - step * pr.v)));
    // Q lies behind the surface: d = (Q − p)·v < 0.
    EXPECT_LT((q.col(pr.index) - pr.p).dot(pr.v), 0.0);
    // p is outside the inflated pillar: at least its radius + inflation from the axis.
    EXPECT_GT((pr.p.head<2>() - Eigen::Vector2d(3.0, 0.0)).norm(),
              0.3 + s.params.inflation - s.map.resolution());
  }
  // Pairs of one run all point the same way round.
  for (const auto& pr : pairs) EXPECT_GT(pr.v.dot(pairs.front().v), 0.0);
}

// Central finite differences of `cost` at x against its analytic gradient.
void ExpectGradient(const EgoCost& cost, const Eigen::VectorXd& x, const char* what) {
  Eigen::VectorXd g(x.size());
  cost.Evaluate(x.data(), g.data());
  EXPECT_GT(g.norm(), 1e-3) << what << ": the term must be active at x";
  for (int i = 0; i < x.size(); ++i) {
    const double h = 1e-6;
    Eigen::VectorXd xp = x, xm = x;
    xp[i] += h;
    xm[i] -= h;
    const double fd = (cost.Evaluate(xp.data(), nullptr) - cost.Evaluate(xm.data(), nullptr)) / (2 * h);
    EXPECT_NEAR(g[i], fd, 1e-5 * std::max(1.0, std::abs(fd))) << what << " variable " << i;
  }
}

TEST(EgoCost, EveryTermsGradientMatchesFiniteDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  const int n = 12;
  ControlPoints q(3, n);
  for (int i = 0; i < n; ++i) q.col(i) = Eigen::Vector3d(0.4 * i + u(rng), u(rng), 1.0 + u(rng));
  const double dt = 0.1;  // fast: velocity and acceleration limits are exceeded
  // Pairs whose penalty argument c falls in each regime: c ≤ 0, 0 < c ≤ s_f, c > s_f.
  std::vector<RepulsionPair> pairs;
  const Eigen::Vector3d v(0.0, 1.0, 0.0);
  pairs.push_back({4, Eigen::Vector3d(q.col(4)) - 1.0 * v, v});   // d = 1.0: c < 0
  pairs.push_back({5, Eigen::Vector3d(q.col(5)) - 0.2 * v, v});   // c = 0.3
  pairs.push_back({6, Eigen::Vector3d(q.col(6)) + 0.4 * v, v});   // c = 0.9 > s_f
  pairs.push_back({7, Eigen::Vector3d(q.col(7)) + 0.1 * v, Eigen::Vector3d(0.6, 0.8, 0.0)});
  Eigen::Matrix3Xd targets(3, n - 4), tangents(3, n - 4);
  for (int j = 0; j < n - 4; ++j) {
    targets.col(j) = Eigen::Vector3d(0.4 * (j + 1), 0.1, 1.05);
    tangents.col(j) = Eigen::Vector3d(1.0, u(rng), 0.0).normalized();
  }
  struct Case {
    const char* what;
    double w_smooth, w_col, w_dyn;
    bool fitness;
  };
  for (const Case& c : {Case{"smoothness", 1.0, 0.0, 0.0, false},
                        Case{"collision", 0.0, 1.0, 0.0, false},
                        Case{"feasibility", 0.0, 0.0, 1.0, false},
                        Case{"fitness", 0.0, 0.0, 0.0, true},
                        Case{"all", 1.0, 0.5, 0.1, true}}) {
    PlannerParams p;
    p.w_smooth = c.w_smooth;
    p.w_col = c.w_col;
    p.w_dyn = c.w_dyn;
    EgoCost cost(q, dt, pairs, p);
    if (c.fitness) cost.SetFitness(targets, tangents, 0.1, 1.0);
    EgoCostTerms terms;
    const Eigen::VectorXd x = cost.Variables();
    cost.Evaluate(x.data(), nullptr, &terms);
    if (c.w_col > 0) {
      EXPECT_GT(terms.collision, 0.0);
    }
    if (c.w_dyn > 0) {
      EXPECT_GT(terms.feasibility, 0.0);
    }
    ExpectGradient(cost, x, c.what);
  }
}

TEST(EgoCost, CollisionPenaltyIsTheC2PiecewiseCubic) {
  const int n = 8;
  ControlPoints q = ControlPoints::Zero(3, n);
  for (int i = 0; i < n; ++i) q(0, i) = 0.5 * i;
  PlannerParams p;
  p.w_smooth = 0.0;
  p.w_dyn = 0.0;
  p.w_col = 1.0;
  const double sf = p.clearance;
  const Eigen::Vector3d v = Eigen::Vector3d::UnitY();
  for (double c : {-0.2, 0.0, 0.25, sf, 0.8, 1.5}) {
    // d = s_f − c along v.
    EgoCost cost(q, 1.0, {{3, Eigen::Vector3d(q.col(3)) - (sf - c) * v, v}}, p);
    const Eigen::VectorXd x = cost.Variables();
    const double expected =
        c <= 0 ? 0.0 : (c <= sf ? c * c * c : 3 * sf * c * c - 3 * sf * sf * c + sf * sf * sf);
    EXPECT_NEAR(cost.Evaluate(x.data(), nullptr), expected, 1e-12) << "c = " << c;
  }
}

TEST(EgoSolve, FreeSpaceGivesTheStraightLineAtTheDesiredSpeed) {
  PillarScene s;
  s.map.Clear();
  const Eigen::Vector3d start(0, 0, 1.2), goal(20, 0, 1.2);
  PlanningQuery q = s.Query(start, Eigen::Vector3d(s.params.v_des, 0, 0), goal);
  ASSERT_EQ(q.initial_path_W.size(), 2u);
  EgoSolveStats stats;
  const PlanResult r = SolveEgo(q, s.params, EgoOptions{}, 1.0, &stats);
  ASSERT_EQ(r.status, PlanStatus::kSuccess) << r.message;
  EXPECT_EQ(stats.pairs, 0);
  const Trajectory& t = r.trajectory;
  for (double time = 0.0; time <= t.Duration(); time += 0.05) {
    const Eigen::Vector3d p = t.Position(time);
    EXPECT_NEAR(p.y(), 0.0, 1e-6);
    EXPECT_NEAR(p.z(), 1.2, 1e-6);
    EXPECT_NEAR(t.Velocity(time).x(), s.params.v_des, 0.02 * s.params.v_des) << time;
  }
  EXPECT_NEAR(t.Duration(), s.params.h_pl / s.params.v_des, 0.05);
}

TEST(EgoSolve, OnePillarIsClearedByTheClearance) {
  PillarScene s;
  // Aim the front end straight at the pillar: the rebound has to push the curve round it.
  PlanningQuery q = s.Query(Eigen::Vector3d(0, 0.05, 1.2), Eigen::Vector3d::Zero(),
                            Eigen::Vector3d(6, 0.05, 1.2));
  EgoSolveStats stats;
  const PlanResult r = SolveEgo(q, s.params, EgoOptions{}, 1.0, &stats);
  ASSERT_EQ(r.status, PlanStatus::kSuccess) << r.message;
  EXPECT_GT(stats.pairs, 0);
  double closest = 1e9;
  const Trajectory& t = r.trajectory;
  for (double time = 0.0; time <= t.Duration(); time += 0.01) {
    const Eigen::Vector3d p = t.Position(time);
    closest = std::min(closest, (p.head<2>() - Eigen::Vector2d(3.0, 0.0)).norm() - 0.3);
  }
  EXPECT_GE(closest, s.params.clearance);
  EXPECT_LT((t.Position(t.Duration()) - q.goal_W).norm(), 1e-9);
  EXPECT_GT(r.compute_units, 1.0);
}

TEST(EgoSolve, ConcurrentResolvesEqualSerialOnesBitForBit) {
  PillarScene s;
  std::vector<PlanningQuery> queries;
  for (int k = 0; k < 4; ++k) {
    queries.push_back(s.Query(Eigen::Vector3d(0, -0.3 + 0.2 * k, 1.0 + 0.1 * k),
                              Eigen::Vector3d(0.5 * k, 0, 0), Eigen::Vector3d(6, 0.1 * k, 1.2)));
  }
  const EgoBackend backend;
  const LocalPlannerOptions options;
  std::vector<PlanOutcome> serial;
  for (const auto& q : queries) serial.push_back(backend.Solve(q, s.params, options));
  std::vector<std::vector<PlanOutcome>> parallel(8);
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t) {
    threads.emplace_back([&, t] {
      for (int rep = 0; rep < 3; ++rep) {
        for (std::size_t k = 0; k < queries.size(); ++k) {
          const std::size_t i = (k + t) % queries.size();
          PlanOutcome out = backend.Solve(queries[i], s.params, options);
          if (rep == 2) parallel[t].push_back(std::move(out));
        }
      }
    });
  }
  for (auto& th : threads) th.join();
  for (int t = 0; t < 8; ++t) {
    for (std::size_t k = 0; k < queries.size(); ++k) {
      const PlanOutcome& a = serial[(k + t) % queries.size()];
      const PlanOutcome& b = parallel[t][k];
      EXPECT_EQ(a.result.status, b.result.status);
      EXPECT_EQ(a.result.trajectory, b.result.trajectory);
      EXPECT_EQ(a.compute_units, b.compute_units);
      EXPECT_EQ(a.result.cost.total, b.result.cost.total);
      EXPECT_EQ(a.result.min_clearance, b.result.min_clearance);
    }
  }
}

// A drone stopped just short of the pillar (where it braked) gets away by the fallback: the
// front end's path flown stop-and-go, judged by the back end's own check, ends at rest at the
// path's end and keeps to the path's segments.
TEST(EgoFallback, FliesTheFrontEndsPathStopAndGoFromRestNextToAnObstacle) {
  PillarScene s;
  PlanningQuery q = s.Query(Eigen::Vector3d(2.45, 0.0, 1.2), Eigen::Vector3d::Zero(),
                            Eigen::Vector3d(6, 0.0, 1.2));
  ASSERT_GE(q.initial_path_W.size(), 2u);
  EXPECT_FALSE(EgoBackend().Fallback(q, s.params, 1.0).has_value()) << "off by default";
  EgoOptions options;
  options.stop_and_go = true;
  const EgoBackend backend(options);
  const std::optional<PlanResult> r = backend.Fallback(q, s.params, 1.0);
  ASSERT_TRUE(r.has_value());
  ASSERT_TRUE(r->Ok()) << r->message;
  const Trajectory& t = r->trajectory;
  EXPECT_LT((t.Position(0.0) - q.p0_W).norm(), 1e-9);
  EXPECT_LT((t.Position(t.Duration()) - q.initial_path_W.back()).norm(), 1e-9);
  EXPECT_LT(t.Velocity(t.Duration()).norm(), 1e-9);
  EXPECT_LE(r->max_speed, 1.0 + 1e-6);
  // Every sample lies on a segment of the path (from p0 to the path's later points).
  std::vector<Eigen::Vector3d> corners = {q.p0_W};
  corners.insert(corners.end(), q.initial_path_W.begin() + 1, q.initial_path_W.end());
  for (double time = 0.0; time <= t.Duration(); time += 0.02) {
    const Eigen::Vector3d p = t.Position(time);
    double nearest = 1e9;
    for (std::size_t k = 1; k < corners.size(); ++k) {
      const Eigen::Vector3d d = corners[k] - corners[k - 1];
      const double u = std::clamp((p - corners[k - 1]).dot(d) / d.squaredNorm(), 0.0, 1.0);
      nearest = std::min(nearest, (p - corners[k - 1] - u * d).norm());
    }
    EXPECT_LT(nearest, 1e-6) << "t = " << time;
  }
  PlanningQuery no_map = q;
  no_map.occupancy.reset();
  EXPECT_EQ(backend.Fallback(no_map, s.params, 1.0)->status, PlanStatus::kInvalidInput);
}

TEST(EgoSolve, QueryWithoutOccupancyIsInvalidInput) {
  PlanningQuery q;
  q.initial_path_W = {Eigen::Vector3d::Zero(), Eigen::Vector3d(5, 0, 0)};
  q.goal_W = q.initial_path_W.back();
  const PlanResult r = SolveEgo(q, PlannerParams{}, EgoOptions{});
  EXPECT_EQ(r.status, PlanStatus::kInvalidInput);
}

}  // namespace
}  // namespace quadtune::planning
