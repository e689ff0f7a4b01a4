#include "quadtune/planning/path_search.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "../config_error_util.hpp"
#include "mapping_scenes.hpp"

namespace quadtune::planning {
namespace {

using ::testing::HasSubstr;
using Eigen::Vector3d;

/// A map (default options: 0.1 m, 12 × 12 × 4 m, inflation 0.1 m, ground) centred at centre_W
/// holding the given hit points.
LocalMap MapWith(const std::vector<Vector3d>& hits, const Vector3d& centre_W = Vector3d(2, 0, 1.5)) {
  LocalMap map(LocalMapOptions{}, centre_W);
  map.Insert(centre_W, hits);
  return map;
}

/// Points filling the plane x = x0 over y ∈ [y0, y1], z ∈ [z0, z1], 5 cm apart.
std::vector<Vector3d> Wall(double x0, double y0, double y1, double z0, double z1) {
  std::vector<Vector3d> pts;
  for (double y = y0; y <= y1 + 1e-9; y += 0.05) {
    for (double z = z0; z <= z1 + 1e-9; z += 0.05) pts.emplace_back(x0 + 0.02, y, z);
  }
  return pts;
}

/// The hollow surface of the cube [c − h, c + h]³, 5 cm apart.
std::vector<Vector3d> Shell(const Vector3d& c, double h) {
  std::vector<Vector3d> pts;
  for (double a = -h; a <= h + 1e-9; a += 0.05) {
    for (double b = -h; b <= h + 1e-9; b += 0.05) {
      for (double s : {-h, h}) {
        pts.push_back(c + Vector3d(s, a, b));
        pts.push_back(c + Vector3d(a, s, b));
        pts.push_back(c + Vector3d(a, b, s));
      }
    }
  }
  return pts;
}

/// Every path cell and every segment (cell path and waypoints) is free on the inflated map.
void ExpectCollisionFree(const LocalMap& map, const PathSearchResult& r) {
  ASSERT_TRUE(r.ok()) << r.message;
  for (const auto& p : r.path) EXPECT_FALSE(map.IsOccupied(p)) << p.transpose();
  for (std::size_t i = 1; i < r.path.size(); ++i) {
    EXPECT_TRUE(map.SegmentFree(r.path[i - 1], r.path[i])) << i;
    EXPECT_LE((r.path[i] - r.path[i - 1]).norm(), std::sqrt(3.0) * 0.1 + 1e-9);
  }
  for (std::size_t i = 1; i < r.waypoints.size(); ++i) {
    EXPECT_TRUE(map.SegmentFree(r.waypoints[i - 1], r.waypoints[i])) << i;
  }
  ASSERT_GE(r.waypoints.size(), 2u);
  EXPECT_EQ(r.waypoints.front(), r.start_W);
  EXPECT_EQ(r.waypoints.back(), r.goal_W);
}

TEST(PathSearch, FindsPathAroundWall) {
  const LocalMap map = MapWith(Wall(2.0, -2.0, 2.0, 0.0, 3.4));
  PathSearcher searcher;
  const Vector3d start(0, 0, 1);
  const Vector3d goal(4, 0, 1);
  ASSERT_FALSE(map.SegmentFree(start, goal));
  const PathSearchResult r = searcher.Search(map, start, goal);
  ExpectCollisionFree(map, r);
  double max_abs_y = 0.0;
  for (const auto& p : r.waypoints) max_abs_y = std::max(max_abs_y, std::abs(p.y()));
  EXPECT_GT(max_abs_y, 2.1);  // around the wall's end, not over or through it
  EXPECT_GT(r.length, 2.0 * std::hypot(2.0, 2.1));
  EXPECT_LT(r.length, 2.0 * std::hypot(2.0, 2.4));
  EXPECT_LE(r.waypoints.size(), 5u);  // pruned to a few corners
  EXPECT_GT(r.expansions, 0);
  EXPECT_THAT(r.message, HasSubstr("path found"));
}

TEST(PathSearch, FailsClearlyWhenGoalIsEnclosed) {
  const Vector3d goal(4, 0, 1.2);
  const LocalMap map = MapWith(Shell(goal, 0.5));
  PathSearchOptions o;
  o.search_margin = 1.0;
  PathSearcher searcher(o);
  const PathSearchResult r = searcher.Search(map, Vector3d(0, 0, 1.2), goal);
  EXPECT_EQ(r.status, PathSearchStatus::kNoPath);
  EXPECT_FALSE(r.ok());
  EXPECT_THAT(r.message, HasSubstr("enclosed"));
  EXPECT_TRUE(r.path.empty());
  EXPECT_TRUE(r.waypoints.empty());
  EXPECT_GT(r.expansions, 1000);
  // Enclosing the start instead fails the same way.
  const PathSearchResult s = searcher.Search(map, goal, Vector3d(0, 0, 1.2));
  EXPECT_EQ(s.status, PathSearchStatus::kNoPath);
  EXPECT_STREQ(ToString(s.status), "no_path");
}

TEST(PathSearch, ReportsExpansionLimitAndOccupiedEnds) {
  const LocalMap map = MapWith(Wall(2.0, -2.0, 2.0, 0.0, 3.4));
  PathSearchOptions o;
  o.max_expansions = 50;
  PathSearcher limited(o);
  const PathSearchResult r = limited.Search(map, Vector3d(0, 0, 1), Vector3d(4, 0, 1));
  EXPECT_EQ(r.status, PathSearchStatus::kExpansionLimit);
  EXPECT_EQ(r.expansions, 50);
  EXPECT_THAT(r.message, HasSubstr("max_expansions"));

  PathSearcher searcher;
  EXPECT_EQ(searcher.Search(map, Vector3d(0, 0, 1), Vector3d(2.02, 0, 1)).status,
            PathSearchStatus::kGoalOccupied);
  // A start inside the inflation layer steps out to the nearest free cell ...
  const Vector3d start(1.95, 0.0, 1.0);
  ASSERT_TRUE(map.IsOccupied(start));
  const PathSearchResult esc = searcher.Search(map, start, Vector3d(0, 0, 1));
  ASSERT_TRUE(esc.ok()) << esc.message;
  EXPECT_FALSE(map.IsOccupied(esc.path.front()));
  EXPECT_LT((esc.path.front() - start).norm(), 0.3);
  // ... unless escaping is disabled.
  o = PathSearchOptions{};
  o.start_escape_radius = 0.0;
  PathSearcher strict(o);
  EXPECT_EQ(strict.Search(map, start, Vector3d(0, 0, 1)).status, PathSearchStatus::kStartOccupied);
  // A search box above max_search_cells is refused.
  o = PathSearchOptions{};
  o.max_search_cells = 1000;
  PathSearcher tiny(o);
  EXPECT_EQ(tiny.Search(map, Vector3d(0, 0, 1), Vector3d(4, 0, 1)).status,
            PathSearchStatus::kSearchBoxTooLarge);
}

TEST(PathSearch, LocalGoalFollowsPlanningHorizon) {
  const LocalMap empty = MapWith({});
  const Vector3d start(0.3, -0.2, 1.0);
  const Vector3d mission(20.3, 4.8, 1.5);
  for (double h_pl : {3.0, 7.5}) {
    const LocalGoal g = ChooseLocalGoal(empty, start, mission, h_pl);
    ASSERT_TRUE(g.found);
    EXPECT_FALSE(g.is_mission_goal);
    EXPECT_NEAR((g.p_W - start).norm(), h_pl, 1e-9);
    EXPECT_NEAR((g.p_W - start).normalized().dot((mission - start).normalized()), 1.0, 1e-12);
  }
  const LocalGoal near = ChooseLocalGoal(empty, start, Vector3d(3, 1, 1.2), 7.5);
  EXPECT_TRUE(near.found && near.is_mission_goal);
  EXPECT_EQ(near.p_W, Vector3d(3, 1, 1.2));

  // A wall at the horizon: the local goal moves back along the line to the first free point.
  const LocalMap walled = MapWith(Wall(7.5, -3.0, 3.0, 0.0, 3.4), Vector3d(4, 0, 1.5));
  const Vector3d s(0, 0, 1);
  const LocalGoal g = ChooseLocalGoal(walled, s, Vector3d(20, 0, 1), 7.5);
  ASSERT_TRUE(g.found);
  EXPECT_FALSE(walled.IsOccupied(g.p_W));
  EXPECT_TRUE(walled.IsOccupied(g.p_W + Vector3d(0.05, 0, 0)));
  EXPECT_NEAR(g.p_W.y(), 0.0, 1e-12);
  EXPECT_GT(g.p_W.x(), 7.2);
  EXPECT_LT(g.p_W.x(), 7.5);

  PathSearcher searcher;
  const PathSearchResult r = searcher.Plan(walled, s, Vector3d(20, 0, 1), 7.5);
  ASSERT_TRUE(r.ok()) << r.message;
  EXPECT_EQ(r.goal_W, g.p_W);
  EXPECT_FALSE(r.goal_is_mission_goal);
  const PathSearchResult r3 = searcher.Plan(walled, s, Vector3d(20, 0, 1), 3.0);
  ASSERT_TRUE(r3.ok());
  EXPECT_NEAR(r3.goal_W.x(), 3.0, 1e-12);
  EXPECT_EQ(r3.waypoints.size(), 2u);  // straight, nothing in the way

  // Nothing free between the drone and the horizon.
  const LocalMap blocked = MapWith(Wall(0.0, -1.0, 1.0, 0.5, 1.5));
  EXPECT_FALSE(ChooseLocalGoal(blocked, Vector3d(0.02, 0, 1), Vector3d(5, 0, 1), 0.05).found);
  EXPECT_EQ(searcher.Plan(blocked, Vector3d(0.02, 0, 1), Vector3d(5, 0, 1), 0.05).status,
            PathSearchStatus::kNoFreeLocalGoal);
  EXPECT_TRUE(
      ::quadtune::test::ThrowsConfigError([&] { (void)ChooseLocalGoal(empty, s, mission, 0.0); },
                                          "h_pl", {"allowed: a number in (0, inf)"}));
}

TEST(PathSearch, ForestPathIsCollisionFreeAndDeterministic) {
  const Vector3d start(0, 0, 1.0);
  const Vector3d mission(15, 1.0, 1.2);
  const physics::ObstacleSet scene = test::Forest(
      1.3, 1.0, 9.0, -4.0, 4.0, 77, {start.head<2>(), Eigen::Vector2d(7.5, 0.5)});
  LocalMap map(LocalMapOptions{}, start);
  for (double x : {0.0, 2.0, 4.0}) {
    const Vector3d o(x, 0, 1);
    map.MoveTo(o);
    map.Insert(o, test::Scan(scene, o, 0.0, 64, 48));
  }
  map.MoveTo(Vector3d(4, 0, 1.5));  // window x ∈ [-2, 10): start and local goal inside
  PathSearcher a;
  PathSearcher b;
  const PathSearchResult r1 = a.Plan(map, start, mission, 7.5);
  ExpectCollisionFree(map, r1);
  EXPECT_GT(r1.length, 7.4);
  // The straight line is blocked somewhere, the path bends around the trunks.
  const PathSearchResult r2 = b.Plan(map, start, mission, 7.5);
  const PathSearchResult r3 = a.Plan(map, start, mission, 7.5);  // reused scratch memory
  for (const PathSearchResult* r : {&r2, &r3}) {
    EXPECT_EQ(r->path, r1.path);
    EXPECT_EQ(r->waypoints, r1.waypoints);
    EXPECT_EQ(r->expansions, r1.expansions);
  }
  // Heavier heuristic weights expand fewer cells and stay collision-free.
  PathSearchOptions o;
  o.heuristic_weight = 2.0;
  PathSearcher greedy(o);
  const PathSearchResult rg = greedy.Plan(map, start, mission, 7.5);
  ExpectCollisionFree(map, rg);
  EXPECT_LE(rg.expansions, r1.expansions);
}

TEST(PathSearch, PruneAndResample) {
  const LocalMap empty = MapWith({});
  std::vector<Vector3d> line;
  for (int i = 0; i <= 20; ++i) line.emplace_back(0.1 * i, 0.05, 1.05);
  const auto pruned = PrunePath(empty, line);
  ASSERT_EQ(pruned.size(), 2u);
  EXPECT_EQ(pruned.front(), line.front());
  EXPECT_EQ(pruned.back(), line.back());
  const auto pts = ResampleByArcLength({Vector3d(0, 0, 1), Vector3d(3, 0, 1), Vector3d(3, 1, 1)}, 4);
  ASSERT_EQ(pts.size(), 5u);
  EXPECT_TRUE(pts[1].isApprox(Vector3d(1, 0, 1)));
  EXPECT_TRUE(pts[2].isApprox(Vector3d(2, 0, 1)));
  EXPECT_TRUE(pts[3].isApprox(Vector3d(3, 0, 1)));
  EXPECT_EQ(pts[4], Vector3d(3, 1, 1));
}

TEST(PathSearchOptions, ValidateRejectsEachBadValue) {
  auto bad = [](auto mutate) {
    PathSearchOptions o;
    mutate(o);
    return o;
  };
  EXPECT_NO_THROW(PathSearchOptions{}.Validate());
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.max_expansions = 0; }).Validate(); }, "max_expansions",
      {"allowed: an integer in [1, 100000000]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.search_margin = -1.0; }).Validate(); }, "search_margin",
      {"allowed: a number in [0, 50]"}));
  EXPECT_TRUE(
      ::quadtune::test::ThrowsConfigError([&] { bad([](auto& o) { o.z_max = 0.1; }).Validate(); },
                                          "z_max", {"allowed: a number in (0.2, inf)"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.z_min = std::nan(""); }).Validate(); }, "z_min",
      {"allowed: a finite number"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.heuristic_weight = 0.5; }).Validate(); }, "heuristic_weight",
      {"allowed: a number in [1, 10]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.start_escape_radius = 3.0; }).Validate(); }, "start_escape_radius",
      {"allowed: a number in [0, 2]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.max_search_cells = 0; }).Validate(); }, "max_search_cells",
      {"allowed: an integer in [1, "}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { PathSearcher(bad([](auto& o) { o.max_expansions = -3; })); }, "max_expansions",
      {"allowed: an integer in [1, 100000000]"}));
  const PathSearchOptions y =
      PathSearchOptions::FromYaml(YamlMap::FromString("max_expansions: 500\nz_max: 2.5\n"));
  EXPECT_EQ(y.max_expansions, 500);
  EXPECT_DOUBLE_EQ(y.z_max, 2.5);
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { (void)PathSearchOptions::FromYaml(YamlMap::FromString("zmax: 2\n")); }, "zmax",
      {"unknown key; allowed keys"}));
}

}  // namespace
}  // namespace quadtune::planning
