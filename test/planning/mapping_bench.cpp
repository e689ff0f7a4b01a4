// Benchmarks of the mapping front end: map update per depth scan, ESDF build, ESDF query, A*.
// Scenes: seeded cylinder forests (1.3 m spacing, radii 0.15–0.3 m, 3 m tall), analytic scans.
//
//   build-map/test/planning/mapping_bench --benchmark_min_time=0.2

#include <benchmark/benchmark.h>

#include "mapping_scenes.hpp"
#include "quadtune/planning/esdf.hpp"
#include "quadtune/planning/local_map.hpp"
#include "quadtune/planning/path_search.hpp"

namespace quadtune::planning {
namespace {

using Eigen::Vector3d;

const physics::ObstacleSet& Scene() {
  static const physics::ObstacleSet scene = test::Forest(
      1.3, 1.0, 30.0, -8.0, 8.0, 2022, {Eigen::Vector2d(0, 0), Eigen::Vector2d(7.5, 0)});
  return scene;
}

/// `n` hits picked evenly from an 80 × 60 scan taken at `origin` looking along +x.
std::vector<Vector3d> ScanPoints(const Vector3d& origin, int n) {
  const std::vector<Vector3d> all = test::Scan(Scene(), origin, 0.0, 80, 60);
  std::vector<Vector3d> out;
  for (int i = 0; i < n; ++i) out.push_back(all[all.size() * static_cast<std::size_t>(i) / n]);
  return out;
}

/// Repeated scans from one pose: the steady state of a hovering or slow drone.
void BM_MapInsertStatic(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  LocalMapOptions o;
  o.clear_free_space = state.range(1) != 0;
  const Vector3d origin(0, 0, 1);
  LocalMap map(o, origin);
  const std::vector<Vector3d> hits = ScanPoints(origin, n);
  map.Insert(origin, hits);
  for (auto _ : state) {
    const InsertSummary s = map.Insert(origin, hits);
    benchmark::DoNotOptimize(s);
  }
  state.SetItemsProcessed(state.iterations() * n);
  state.counters["occupied_cells"] = static_cast<double>(map.CountRawOccupied());
}
BENCHMARK(BM_MapInsertStatic)
    ->ArgsProduct({{1000, 3000}, {0, 1}})
    ->ArgNames({"points", "ray_clearing"})
    ->Unit(benchmark::kMicrosecond);

/// A forest that repeats every 10.4 m along x (8 trunk spacings), from x = -10.4 to 41.6 m.
const physics::ObstacleSet& PeriodicScene() {
  static const physics::ObstacleSet scene = [] {
    const physics::ObstacleSet tile = test::Forest(1.3, 1.0, 1.0 + 7 * 1.3, -8.0, 8.0, 7);
    physics::ObstacleSet out;
    for (int k = -1; k < 4; ++k) {
      for (auto c : tile.cylinders) {
        c.center_W.x() += 10.4 * k;
        out.cylinders.push_back(c);
      }
    }
    return out;
  }();
  return scene;
}

/// Flying at 2 m/s along x with a 30 Hz sensor through a periodic forest: every scan moves the
/// window ≈ 6.7 cm (MoveTo + Insert). The 156 scans of one period are precomputed; later periods
/// reuse them shifted by 10.4 m (the shift, 1–3 µs, is inside the timing).
void BM_MapInsertMoving(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  LocalMapOptions o;
  o.clear_free_space = state.range(1) != 0;
  constexpr int kPoses = 156;
  constexpr double kPeriod = 10.4;
  std::vector<std::vector<Vector3d>> scans;
  for (int i = 0; i < kPoses; ++i) {
    const Vector3d origin(kPeriod / kPoses * i, 0.0, 1.0);
    const std::vector<Vector3d> all = test::Scan(PeriodicScene(), origin, 0.0, 80, 60);
    std::vector<Vector3d> pick;
    for (int j = 0; j < n; ++j) pick.push_back(all[all.size() * static_cast<std::size_t>(j) / n]);
    scans.push_back(std::move(pick));
  }
  LocalMap map(o, Vector3d(0, 0, 1));
  std::vector<Vector3d> shifted(static_cast<std::size_t>(n));
  long step = 0;
  for (auto _ : state) {
    const int i = static_cast<int>(step % kPoses);
    const double offset = kPeriod * static_cast<double>(step / kPoses);
    const Vector3d origin(kPeriod / kPoses * i + offset, 0.0, 1.0);
    for (int j = 0; j < n; ++j) {
      shifted[static_cast<std::size_t>(j)] = scans[static_cast<std::size_t>(i)][static_cast<std::size_t>(j)];
      shifted[static_cast<std::size_t>(j)].x() += offset;
    }
    map.MoveTo(origin);
    const InsertSummary s = map.Insert(origin, shifted);
    benchmark::DoNotOptimize(s);
    ++step;
  }
  state.SetItemsProcessed(state.iterations() * n);
  state.counters["occupied_cells"] = static_cast<double>(map.CountRawOccupied());
}
BENCHMARK(BM_MapInsertMoving)
    ->ArgsProduct({{1000, 3000}, {0, 1}})
    ->ArgNames({"points", "ray_clearing"})
    ->Unit(benchmark::kMicrosecond);

/// A map of the forest around the origin, as a drone would have it after flying 5 m in.
LocalMap ForestMap() {
  LocalMap map(LocalMapOptions{}, Vector3d(3, 0, 1.5));
  for (double x : {-1.0, 0.0, 1.0, 2.0, 3.0}) {
    for (double yaw : {-0.6, 0.0, 0.6}) {
      const Vector3d o(x, 0.0, 1.0);
      map.Insert(o, test::Scan(Scene(), o, yaw, 80, 60));
    }
  }
  return map;
}

/// ESDF of a 10 × 6 × 3 m box at 0.1 m (100 × 60 × 30 cells + one ground layer).
void BM_EsdfBuild(benchmark::State& state) {
  const LocalMap map = ForestMap();
  EsdfBuilder builder;
  const Eigen::AlignedBox3d box(Vector3d(-1.0, -3.0, 0.0), Vector3d(8.99, 2.99, 2.99));
  EsdfOptions o;
  o.max_distance = static_cast<double>(state.range(0)) / 10.0;
  std::size_t bytes = 0;
  std::size_t cells = 0;
  for (auto _ : state) {
    const Esdf esdf = builder.Build(map, box, o);
    bytes = esdf.MemoryBytes();
    cells = static_cast<std::size_t>(esdf.dims().prod());
    benchmark::DoNotOptimize(esdf);
  }
  state.counters["cells"] = static_cast<double>(cells);
  state.counters["snapshot_bytes"] = static_cast<double>(bytes);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(cells));
}
BENCHMARK(BM_EsdfBuild)->Arg(10)->Arg(20)->ArgName("max_dist_dm")->Unit(benchmark::kMicrosecond);

/// One Evaluate with gradient at random points in the box.
void BM_EsdfEvaluate(benchmark::State& state) {
  const LocalMap map = ForestMap();
  const Esdf esdf = Esdf::Build(map, Eigen::AlignedBox3d(Vector3d(-1.0, -3.0, 0.0),
                                                         Vector3d(8.99, 2.99, 2.99)));
  Rng rng(1);
  std::vector<Vector3d> pts(4096);
  for (auto& p : pts) p = Vector3d(Uniform(rng, -1, 9), Uniform(rng, -3, 3), Uniform(rng, 0, 3));
  std::size_t i = 0;
  Vector3d grad;
  const DistanceField& field = esdf;
  for (auto _ : state) {
    benchmark::DoNotOptimize(field.Evaluate(pts[i], &grad));
    benchmark::DoNotOptimize(grad);
    i = (i + 1) & 4095;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_EsdfEvaluate);

/// A* (26-connected, pruning included) through the forest to a local goal 7.5 m ahead.
void BM_AStarForest(benchmark::State& state) {
  const LocalMap map = ForestMap();
  PathSearchOptions o;
  o.heuristic_weight = static_cast<double>(state.range(0)) / 10.0;
  PathSearcher searcher(o);
  const Vector3d start(0, 0, 1.0);
  const Vector3d mission(20, 0.3, 1.2);
  PathSearchResult r;
  for (auto _ : state) {
    r = searcher.Plan(map, start, mission, 7.5);
    benchmark::DoNotOptimize(r);
  }
  if (!r.ok()) state.SkipWithError(r.message.c_str());
  state.counters["expansions"] = r.expansions;
  state.counters["path_cells"] = static_cast<double>(r.path.size());
  state.counters["waypoints"] = static_cast<double>(r.waypoints.size());
  state.counters["length_m"] = r.length;
}
BENCHMARK(BM_AStarForest)->Arg(10)->Arg(15)->Arg(20)->ArgName("heuristic_weight_x10")
    ->Unit(benchmark::kMicrosecond);

/// Collision check of a 7.5 m segment against the map (the executing-trajectory check).
void BM_SegmentCheck(benchmark::State& state) {
  const LocalMap map = ForestMap();
  const Vector3d a(0, 0, 1.0);
  const Vector3d b(7.5, 0.4, 1.3);
  for (auto _ : state) benchmark::DoNotOptimize(map.SegmentCollision(a, b));
}
BENCHMARK(BM_SegmentCheck);

}  // namespace
}  // namespace quadtune::planning

BENCHMARK_MAIN();
