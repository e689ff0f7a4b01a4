// Benchmarks of the physics module (Google Benchmark). Run:
//   build/test/physics/physics_bench --benchmark_min_time=0.5
#include <benchmark/benchmark.h>
#include <btBulletDynamicsCommon.h>
#include <malloc.h>
#include <oneapi/tbb/parallel_for.h>
#include <oneapi/tbb/task_arena.h>

#include <cmath>
#include <memory>
#include <vector>

#include "physics_test_util.hpp"
#include "quadtune/physics/depth_sensor.hpp"
#include "quadtune/physics/world.hpp"

namespace quadtune::physics {
namespace {

// 100 pillars + 100 rings over 40 × 40 m: EGO-Planner's forest at half its maximum density.
const ObstacleSet& Forest200() {
  static const ObstacleSet set = testing::RandomForest(2024, 100, 100, 40.0);
  return set;
}

TrackingReference Wander(double t) {
  TrackingReference r;
  r.p_W = {20.0 + 4.0 * std::sin(0.4 * t), 20.0 + 4.0 * std::sin(0.2 * t), 1.8};
  r.v_W = {1.6 * std::cos(0.4 * t), 0.8 * std::cos(0.2 * t), 0.0};
  r.a_W = {-0.64 * std::sin(0.4 * t), -0.16 * std::sin(0.2 * t), 0.0};
  return r;
}

// One physics step of the full closed loop: controller (every 2nd step), motors, forces,
// Bullet, collision monitor.
void BM_ClosedLoopStep(benchmark::State& state) {
  const DroneDescription d;
  WorldOptions options;
  options.collision_response = CollisionResponse::kPassThrough;
  World world(Forest200(), d, options, DroneState::Hover(d, {20, 20, 1.8}));
  world.SetReference(Wander);
  for (auto _ : state) {
    world.Step();
    if (world.time() > 60.0) {
      state.PauseTiming();
      world.Reset(DroneState::Hover(d, {20, 20, 1.8}));
      world.SetReference(Wander);
      state.ResumeTiming();
    }
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ClosedLoopStep);

// A raw Bullet step of the same world: the drone hovering with gravity switched off for its
// body, nothing else.
void BM_RawBulletStep(benchmark::State& state) {
  const DroneDescription d;
  WorldOptions options;
  options.collision_response = CollisionResponse::kPassThrough;
  World world(Forest200(), d, options, DroneState::Hover(d, {20, 20, 1.8}));
  btRigidBody& body = world.bullet_body();
  body.setGravity(btVector3(0, 0, 0));
  body.setLinearVelocity(btVector3(1.0f, 0.5f, 0.0f));
  btDiscreteDynamicsWorld& bw = world.bullet_world();
  const btScalar dt = 1.0f / 1000.0f;
  for (auto _ : state) {
    bw.stepSimulation(dt, 0, dt);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RawBulletStep);

// Heap bytes per world with 200 obstacles (mallinfo2 delta over 16 worlds). Args: collision
// pool size; 0 = each world builds its own obstacle geometry, 1 = the 16 worlds share one
// ObstacleGeometry (the world pool's case; the geometry itself is built before measuring).
void BM_MemoryPerWorld(benchmark::State& state) {
  const DroneDescription d;
  WorldOptions options;
  options.collision_pool_size = static_cast<int>(state.range(0));
  const bool shared = state.range(1) != 0;
  const auto geometry = ObstacleGeometry::Make(Forest200(), options);
  double per_world = 0.0;
  for (auto _ : state) {
    malloc_trim(0);
    const std::size_t before = mallinfo2().uordblks;
    std::vector<std::unique_ptr<World>> worlds;
    for (int i = 0; i < 16; ++i) {
      worlds.push_back(shared ? std::make_unique<World>(geometry, d, options,
                                                        DroneState::Hover(d, {20, 20, 1.8}))
                              : std::make_unique<World>(Forest200(), d, options,
                                                        DroneState::Hover(d, {20, 20, 1.8})));
      worlds.back()->Advance(0.05);
    }
    const std::size_t after = mallinfo2().uordblks;
    per_world = static_cast<double>(after - before) / 16.0;
    benchmark::DoNotOptimize(worlds.data());
  }
  state.counters["bytes_per_world"] = per_world;
  state.counters["MiB_per_world"] = per_world / (1024.0 * 1024.0);
}
BENCHMARK(BM_MemoryPerWorld)
    ->Args({64, 0})->Args({256, 0})->Args({64, 1})->Args({256, 1})->Iterations(1);

// Depth scans of a 64×48 camera flying through the forest (rays per second).
void BM_DepthScan(benchmark::State& state) {
  const DroneDescription d;
  World world(Forest200(), d, {}, DroneState::Hover(d, {20, 20, 1.8}));
  DepthSensorOptions options;
  options.width = static_cast<int>(state.range(0));
  options.height = static_cast<int>(state.range(1));
  DepthSensor sensor(options);
  DepthScan scan;
  std::int64_t k = 0;
  for (auto _ : state) {
    const double t = 0.05 * static_cast<double>(k++ % 2000);
    const TrackingReference r = Wander(t);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(std::atan2(r.v_W.y(), r.v_W.x()), Eigen::Vector3d::UnitZ()));
    sensor.Scan(world.ray_caster(), r.p_W, q, t, scan);
    benchmark::DoNotOptimize(scan.hits_W.data());
  }
  state.SetItemsProcessed(state.iterations() * options.width * options.height);
}
BENCHMARK(BM_DepthScan)->Args({64, 48})->Args({160, 120});

// The same rays through Bullet's rayTest, for comparison.
void BM_BulletRayTest(benchmark::State& state) {
  const DroneDescription d;
  World world(Forest200(), d, {}, DroneState::Hover(d, {-20, -20, 1.8}));
  DepthSensor sensor;
  std::int64_t k = 0;
  for (auto _ : state) {
    const double t = 0.05 * static_cast<double>(k++ % 2000);
    const TrackingReference r = Wander(t);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(std::atan2(r.v_W.y(), r.v_W.x()), Eigen::Vector3d::UnitZ()));
    for (const auto& d_C : sensor.directions_C()) {
      const Eigen::Vector3d d_W = q * d_C;
      benchmark::DoNotOptimize(world.BulletRayDistance(r.p_W, r.p_W + 5.0 * d_W));
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(sensor.directions_C().size()));
}
BENCHMARK(BM_BulletRayTest);

// 32 worlds, each advanced 1 s (1000 closed-loop steps) per iteration, on N threads.
void BM_ThirtyTwoWorlds(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  const DroneDescription d;
  WorldOptions options;
  options.collision_response = CollisionResponse::kPassThrough;
  std::vector<std::unique_ptr<World>> worlds;
  const auto geometry = ObstacleGeometry::Make(Forest200(), options);
  for (int i = 0; i < 32; ++i) {
    options.seed = static_cast<std::uint64_t>(i);
    worlds.push_back(std::make_unique<World>(geometry, d, options, DroneState::Hover(d, {20, 20, 1.8})));
    worlds.back()->SetReference([i](double t) { return Wander(t + i); });
  }
  tbb::task_arena arena(threads);
  for (auto _ : state) {
    arena.execute([&] {
      tbb::parallel_for(0, 32, [&](int i) { worlds[static_cast<std::size_t>(i)]->Advance(1.0); }, tbb::simple_partitioner());
    });
  }
  state.SetItemsProcessed(state.iterations() * 32 * 1000);
}
BENCHMARK(BM_ThirtyTwoWorlds)->Arg(1)->Arg(2)->UseRealTime()->MinTime(2.0);

}  // namespace
}  // namespace quadtune::physics

BENCHMARK_MAIN();
