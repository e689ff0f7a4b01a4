#include "quadtune/planning/local_map.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <tuple>

#include "../config_error_util.hpp"
#include "mapping_scenes.hpp"
#include "quadtune/common/random.hpp"

namespace quadtune::planning {
namespace {

using Eigen::Vector3d;

LocalMapOptions SmallOptions(double inflation = 0.0) {
  LocalMapOptions o;
  o.resolution = 0.1;
  o.size = Vector3d(4.0, 3.0, 2.0);
  o.inflation = inflation;
  o.ground_is_obstacle = false;
  return o;
}

std::tuple<int, int, int> Key(const CellIndex& g) { return {g.x(), g.y(), g.z()}; }

TEST(LocalMap, HitsBecomeOccupied) {
  LocalMap map(SmallOptions(), Vector3d(0, 0, 1));
  const std::vector<Vector3d> hits = {{1.03, 0.51, 1.2}, {-1.5, -0.77, 0.45}, {1.03, 0.52, 1.21}};
  const InsertSummary s = map.Insert(Vector3d(0, 0, 1), hits);
  EXPECT_EQ(s.points_used, 3);
  EXPECT_EQ(s.cells_occupied, 2);  // the first and third hit share a cell
  for (const auto& h : hits) EXPECT_TRUE(map.IsOccupiedRaw(h));
  for (const auto& h : hits) EXPECT_TRUE(map.IsOccupied(h));
  EXPECT_FALSE(map.IsOccupied(Vector3d(1.13, 0.51, 1.2)));  // next cell: no inflation
  EXPECT_FALSE(map.IsOccupied(Vector3d(0, 0, 1)));
  EXPECT_EQ(map.CountRawOccupied(), 2u);
}

TEST(LocalMap, DropsHitsOutsideWindowOrRange) {
  LocalMapOptions o = SmallOptions();
  o.max_range = 3.0;
  LocalMap map(o, Vector3d(0, 0, 1));
  const std::vector<Vector3d> hits = {
      {0.5, 0.0, 1.0},                                        // used
      {2.5, 0.0, 1.0},                                        // in range, outside window (x ≥ 2)
      {0.0, 0.0, 4.5},                                        // out of range (3.5 m)
      {std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0}};  // not finite
  const InsertSummary s = map.Insert(Vector3d(0, 0, 1), hits);
  EXPECT_EQ(s.points_used, 1);
  EXPECT_EQ(s.points_out_of_window, 1);
  EXPECT_EQ(s.points_out_of_range, 2);
  EXPECT_EQ(map.CountRawOccupied(), 1u);
}

TEST(LocalMap, InflationCoversCellsWithinRadius) {
  LocalMap map(SmallOptions(0.2), Vector3d(0, 0, 1));
  const CellIndex c = map.CellOf(Vector3d(0.05, 0.05, 1.05));
  map.Insert(Vector3d(0, 0, 1), std::vector<Vector3d>{map.CellCenter(c)});
  auto occ = [&](int dx, int dy, int dz) { return map.IsOccupiedCell(c + CellIndex(dx, dy, dz)); };
  // A cell is inflated when its centre is within 0.2 m of the hit cell's cube.
  EXPECT_TRUE(occ(0, 0, 0));
  EXPECT_TRUE(occ(2, 0, 0));    // 0.15 m
  EXPECT_TRUE(occ(0, -2, 0));
  EXPECT_TRUE(occ(1, 1, 1));    // 0.087 m
  EXPECT_TRUE(occ(2, 1, 1));    // 0.166 m
  EXPECT_FALSE(occ(3, 0, 0));   // 0.25 m
  EXPECT_FALSE(occ(2, 2, 0));   // 0.21 m
  EXPECT_FALSE(occ(2, 2, 2));   // 0.26 m
  EXPECT_FALSE(map.IsOccupiedRawCell(c + CellIndex(1, 0, 0)));
  // The segment check sees the inflated obstacle.
  const Vector3d a = map.CellCenter(c + CellIndex(-5, 2, 0));
  const Vector3d b = map.CellCenter(c + CellIndex(5, 2, 0));
  EXPECT_FALSE(map.SegmentFree(a, b));
  EXPECT_FALSE(map.SegmentCollision(a, b, /*inflated=*/false).has_value());
  EXPECT_TRUE(map.SegmentFree(map.CellCenter(c + CellIndex(-5, 3, 0)),
                              map.CellCenter(c + CellIndex(5, 3, 0))));
}

TEST(LocalMap, SegmentCollisionReportsEntryFraction) {
  LocalMap map(SmallOptions(), Vector3d(0, 0, 1));
  std::vector<Vector3d> wall;
  for (double y = -1.0; y <= 1.0; y += 0.05) {
    for (double z = 0.5; z <= 1.5; z += 0.05) wall.emplace_back(1.05, y, z);
  }
  map.Insert(Vector3d(0, 0, 1), wall);
  const auto t = map.SegmentCollision(Vector3d(0.0, 0.02, 1.02), Vector3d(2.0, 0.02, 1.02));
  ASSERT_TRUE(t.has_value());
  EXPECT_NEAR(*t, 0.5, 1e-9);  // enters the cell [1.0, 1.1) halfway along
  EXPECT_EQ(map.SegmentCollision(Vector3d(1.05, 0.0, 1.0), Vector3d(0, 0, 1)), 0.0);
  EXPECT_TRUE(map.SegmentFree(Vector3d(0.0, 0.0, 1.0), Vector3d(0.9, 0.8, 0.6)));
  // A diagonal segment through the shared corner of occupied cells is blocked (supercover).
  LocalMap corner(SmallOptions(), Vector3d(0, 0, 1));
  corner.Insert(Vector3d(0, 0, 1), std::vector<Vector3d>{{0.15, 0.05, 1.05}});
  EXPECT_FALSE(corner.SegmentFree(Vector3d(0.05, 0.05, 1.05), Vector3d(0.15, 0.15, 1.05)));
  EXPECT_TRUE(corner.SegmentFree(Vector3d(0.05, 0.05, 1.05), Vector3d(0.05, 0.15, 1.05)));
}

TEST(LocalMap, GroundIsAnObstacleBelowGroundHeight) {
  LocalMapOptions o = SmallOptions(0.1);
  o.ground_is_obstacle = true;
  LocalMap map(o, Vector3d(0, 0, 1));
  EXPECT_TRUE(map.IsOccupiedRaw(Vector3d(0.3, 0.3, -0.05)));
  EXPECT_FALSE(map.IsOccupiedRaw(Vector3d(0.3, 0.3, 0.05)));
  EXPECT_TRUE(map.IsOccupied(Vector3d(0.3, 0.3, 0.05)));   // inflated by 0.1 m
  EXPECT_FALSE(map.IsOccupied(Vector3d(0.3, 0.3, 0.15)));
  EXPECT_TRUE(map.IsOccupied(Vector3d(50.0, 0.3, -1.0)));  // also outside the window
  EXPECT_EQ(map.ground_cell_z(), 0);
}

TEST(LocalMap, RemembersEarlierObstaclesInsideWindow) {
  LocalMap map(SmallOptions(0.1), Vector3d(0, 0, 1));
  map.Insert(Vector3d(0, 0, 1), std::vector<Vector3d>{{1.0, 1.0, 1.0}});
  map.Insert(Vector3d(0, 0, 1), std::vector<Vector3d>{{-1.0, -1.0, 1.0}});  // looking elsewhere
  map.Insert(Vector3d(0, 0, 1), std::vector<Vector3d>{});
  EXPECT_TRUE(map.IsOccupiedRaw(Vector3d(1.0, 1.0, 1.0)));
  EXPECT_TRUE(map.IsOccupiedRaw(Vector3d(-1.0, -1.0, 1.0)));
  map.MoveTo(Vector3d(0.5, 0.2, 1.0));  // both still inside
  EXPECT_TRUE(map.IsOccupiedRaw(Vector3d(1.0, 1.0, 1.0)));
  EXPECT_TRUE(map.IsOccupied(Vector3d(1.1, 1.0, 1.0)));
  EXPECT_TRUE(map.IsOccupiedRaw(Vector3d(-1.0, -1.0, 1.0)));
}

// Brute force: the nearest raw-occupied cell cube within radius, over every cell of the cube of
// cells around p.
double BruteClearance(const LocalMap& map, const Vector3d& p, double radius) {
  const double res = map.resolution();
  const int r = static_cast<int>(std::ceil(radius / res)) + 1;
  const CellIndex c = map.CellOf(p);
  double best = radius;
  for (int dz = -r; dz <= r; ++dz) {
    for (int dy = -r; dy <= r; ++dy) {
      for (int dx = -r; dx <= r; ++dx) {
        const CellIndex g = c + CellIndex(dx, dy, dz);
        if (!map.IsOccupiedRawCell(g)) continue;
        Vector3d gap;
        for (int k = 0; k < 3; ++k) {
          const double lo = g[k] * res;
          gap[k] = std::max({lo - p[k], p[k] - (lo + res), 0.0});
        }
        best = std::min(best, gap.norm());
      }
    }
  }
  return best;
}

TEST(LocalMap, RawClearanceIsTheDistanceToTheNearestRawOccupiedCell) {
  LocalMapOptions o = SmallOptions(0.15);
  o.ground_is_obstacle = true;
  o.ground_height = 0.3;
  LocalMap map(o, Vector3d(0, 0, 1));
  map.MoveTo(Vector3d(0.73, -0.41, 1.1));  // a window that wraps in the ring buffer
  Rng rng(17);
  std::vector<Vector3d> hits;
  for (int i = 0; i < 60; ++i) {
    hits.emplace_back(Uniform(rng, -1.2, 2.6), Uniform(rng, -1.9, 1.0), Uniform(rng, 0.2, 2.0));
  }
  map.Insert(Vector3d(0.73, -0.41, 1.1), hits);
  ASSERT_GT(map.CountRawOccupied(), 40u);
  int nearer = 0;
  for (int i = 0; i < 400; ++i) {
    // Points inside and just outside the window, some near the ground.
    const Vector3d p(Uniform(rng, -1.6, 3.1), Uniform(rng, -2.2, 1.4), Uniform(rng, 0.0, 2.3));
    const double radius = Uniform(rng, 0.05, 0.8);
    const double expected = BruteClearance(map, p, radius);
    EXPECT_NEAR(map.RawClearance(p, radius), expected, 1e-12) << p.transpose() << " r " << radius;
    nearer += expected < radius ? 1 : 0;
  }
  EXPECT_GT(nearer, 100);  // the check compares real distances, not only the cap
  // Outside the window only the ground counts.
  const Vector3d outside(3.5, -0.4, 0.45);
  ASSERT_FALSE(map.InWindow(outside));
  EXPECT_LT(map.RawClearance(outside, 1.0), 0.3);
  EXPECT_DOUBLE_EQ(map.RawClearance(outside, 1.0), BruteClearance(map, outside, 1.0));
}

TEST(LocalMap, ForgetsCellsThatLeaveTheWindow) {
  LocalMap map(SmallOptions(0.1), Vector3d(0, 0, 1));
  const Vector3d obstacle(-1.5, 0.0, 1.0);
  map.Insert(Vector3d(0, 0, 1), std::vector<Vector3d>{obstacle});
  ASSERT_TRUE(map.IsOccupied(obstacle));
  map.MoveTo(Vector3d(1.0, 0.0, 1.0));  // window x ∈ [-1, 3): the obstacle left
  EXPECT_FALSE(map.InWindow(obstacle));
  EXPECT_FALSE(map.IsOccupied(obstacle));
  map.MoveTo(Vector3d(0.0, 0.0, 1.0));  // back: the cell is inside again but forgotten
  EXPECT_TRUE(map.InWindow(obstacle));
  EXPECT_FALSE(map.IsOccupiedRaw(obstacle));
  EXPECT_FALSE(map.IsOccupied(obstacle));
  EXPECT_FALSE(map.IsOccupied(obstacle + Vector3d(0.1, 0, 0)));  // its inflation is gone too
  EXPECT_EQ(map.CountRawOccupied(), 0u);
  map.MoveTo(Vector3d(100.0, 0.0, 1.0));  // a jump farther than the window: full reset
  EXPECT_EQ(map.CountRawOccupied(), 0u);
}

// Random hits and random window moves; after every move the map must equal a map built from
// scratch at the current window from the cells that never left the window since they were hit
// (raw and inflated occupancy alike, which checks the incremental inflation bookkeeping).
TEST(LocalMap, RollingKeepsInsideCellsAndMatchesFreshMap) {
  for (double inflation : {0.0, 0.1, 0.25}) {
    LocalMapOptions o = SmallOptions(inflation);
    o.size = Vector3d(2.4, 2.0, 1.2);
    LocalMap map(o, Vector3d(0, 0, 1));
    Rng rng(DeriveSeed(7, {static_cast<std::uint64_t>(inflation * 100)}));
    std::set<std::tuple<int, int, int>> expected;
    Vector3d center(0, 0, 1);
    for (int round = 0; round < 25; ++round) {
      std::vector<Vector3d> hits;
      const Eigen::AlignedBox3d w = map.WindowBox();
      for (int i = 0; i < 40; ++i) {
        hits.emplace_back(Uniform(rng, w.min().x(), w.max().x()),
                          Uniform(rng, w.min().y(), w.max().y()),
                          Uniform(rng, w.min().z(), w.max().z()));
      }
      map.Insert(center, hits);
      for (const auto& h : hits) expected.insert(Key(map.CellOf(h)));
      // Moves of 0–6 cells per axis, sometimes negative, sometimes several axes at once.
      center += Vector3d(0.1 * static_cast<double>(UniformInt(rng, -6, 6)),
                         0.1 * static_cast<double>(UniformInt(rng, -4, 4)),
                         0.1 * static_cast<double>(UniformInt(rng, -2, 2)));
      map.MoveTo(center);
      for (auto it = expected.begin(); it != expected.end();) {
        const auto [x, y, z] = *it;
        it = map.InWindow(CellIndex(x, y, z)) ? std::next(it) : expected.erase(it);
      }
      LocalMap fresh(o, center);
      ASSERT_EQ(fresh.window_origin(), map.window_origin());
      std::vector<Vector3d> centres;
      for (const auto& [x, y, z] : expected) centres.push_back(fresh.CellCenter(CellIndex(x, y, z)));
      fresh.Insert(center, centres);
      std::vector<std::uint8_t> a;
      std::vector<std::uint8_t> b;
      for (bool inflated : {false, true}) {
        map.ExtractOccupancy(map.window_origin(), map.window_cells(), inflated, &a);
        fresh.ExtractOccupancy(map.window_origin(), map.window_cells(), inflated, &b);
        ASSERT_EQ(a, b) << "inflation " << inflation << " round " << round << " inflated "
                        << inflated;
      }
      ASSERT_EQ(map.CountRawOccupied(), expected.size());
    }
  }
}

TEST(LocalMap, RayClearingFreesCellsSeenThrough) {
  LocalMapOptions o = SmallOptions(0.1);
  o.clear_free_space = true;
  o.misses_to_free = 2;
  LocalMap map(o, Vector3d(0, 0, 1));
  const Vector3d stale(0.55, 0.05, 1.05);
  map.Insert(Vector3d(0, 0, 1), std::vector<Vector3d>{stale});
  ASSERT_TRUE(map.IsOccupiedRaw(stale));
  const std::vector<Vector3d> through = {{1.55, 0.05, 1.05}};  // the ray passes through `stale`
  const Vector3d sensor(0.05, 0.05, 1.05);
  InsertSummary s = map.Insert(sensor, through);
  EXPECT_TRUE(map.IsOccupiedRaw(stale));  // one miss is not enough
  EXPECT_EQ(s.cells_freed, 0);
  s = map.Insert(sensor, through);
  EXPECT_EQ(s.cells_freed, 1);
  EXPECT_FALSE(map.IsOccupiedRaw(stale));
  EXPECT_FALSE(map.IsOccupied(stale));
  EXPECT_TRUE(map.IsOccupiedRaw(through[0]));  // the hit itself stays
  // A hit in the same scan wins over misses of other rays.
  map.Insert(sensor, std::vector<Vector3d>{stale, {0.95, 0.05, 1.05}});
  EXPECT_TRUE(map.IsOccupiedRaw(stale));
}

TEST(LocalMap, ScanOfForestMarksSurfacesOnly) {
  const physics::ObstacleSet scene =
      test::Forest(1.3, 1.0, 6.0, -3.0, 3.0, 11, {Eigen::Vector2d(0, 0)});
  LocalMapOptions o;
  o.inflation = 0.1;
  LocalMap map(o, Vector3d(0, 0, 1));
  const Vector3d sensor(0, 0, 1);
  const std::vector<Vector3d> hits = test::Scan(scene, sensor, 0.0, 64, 48);
  ASSERT_GT(hits.size(), 1000u);
  const InsertSummary s = map.Insert(sensor, hits);
  EXPECT_EQ(s.points_used, static_cast<int>(hits.size()));
  for (const auto& h : hits) ASSERT_TRUE(map.IsOccupiedRaw(h));
  // Every raw-occupied cell above the ground lies within a cell diagonal of a surface.
  Rng rng(3);
  int checked = 0;
  for (int i = 0; i < 20000; ++i) {
    const Vector3d p(Uniform(rng, 0, 6), Uniform(rng, -6, 6), Uniform(rng, 0.3, 1.9));
    if (!map.IsOccupiedRaw(p)) continue;
    ++checked;
    EXPECT_LT(std::abs(scene.Distance(map.CellCenter(map.CellOf(p)))), 0.09);
  }
  EXPECT_GT(checked, 50);
}

TEST(LocalMapOptions, ValidateRejectsEachBadValue) {
  auto bad = [](auto mutate) {
    LocalMapOptions o;
    mutate(o);
    return o;
  };
  EXPECT_NO_THROW(LocalMapOptions{}.Validate());
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.resolution = 0.0; }).Validate(); }, "resolution",
      {"allowed: a number in (0, 1]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.resolution = 2.0; }).Validate(); }, "resolution",
      {"allowed: a number in (0, 1]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.size.x() = 0.1; }).Validate(); }, "size.x",
      {"allowed: a number in [0.2, 409.6]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.size = Vector3d(400, 400, 100); }).Validate(); }, "size",
      {"the window holds"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.inflation = -0.1; }).Validate(); }, "inflation",
      {"allowed: a number in [0, 1.5]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.inflation = 2.0; }).Validate(); }, "inflation",
      {"allowed: a number in [0, 1.5]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.max_range = 0.0; }).Validate(); }, "max_range",
      {"allowed: a number in (0, inf)"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.misses_to_free = 0; }).Validate(); }, "misses_to_free",
      {"allowed: an integer in [1, 100]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { bad([](auto& o) { o.ground_height = std::nan(""); }).Validate(); }, "ground_height",
      {"allowed: a finite number"}));
  try {
    bad([](auto& o) { o.inflation = 5.0; }).Validate("map.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "inflation");
    EXPECT_EQ(e.file(), "map.yaml");
  }
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { (void)LocalMap(bad([](auto& o) { o.resolution = -1.0; })); }, "resolution",
      {"allowed: a number in (0, 1]"}));
}

TEST(LocalMapOptions, ReadsYamlAndPlannerParams) {
  const YamlMap y = YamlMap::FromString("resolution: 0.2\nsize: [10, 8, 3]\ninflation: 0.3\n");
  const LocalMapOptions o = LocalMapOptions::FromYaml(y);
  EXPECT_DOUBLE_EQ(o.resolution, 0.2);
  EXPECT_DOUBLE_EQ(o.size.y(), 8.0);
  EXPECT_DOUBLE_EQ(o.inflation, 0.3);
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { LocalMapOptions::FromYaml(YamlMap::FromString("resolutoin: 0.2\n")); }, "resolutoin",
      {"unknown key; allowed keys"}));
  PlannerParams p;
  p.map_resolution = 0.15;
  p.inflation = 0.2;
  const LocalMapOptions q = LocalMapOptions::FromPlannerParams(p);
  EXPECT_DOUBLE_EQ(q.resolution, 0.15);
  EXPECT_DOUBLE_EQ(q.inflation, 0.2);
}

}  // namespace
}  // namespace quadtune::planning
