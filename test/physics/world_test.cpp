#include "quadtune/physics/world.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

#include "../config_error_util.hpp"
#include "physics_test_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/common/parallel_for.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::physics {
namespace {

DroneDescription NoDrag() {
  DroneDescription d;
  d.linear_drag.setZero();
  return d;
}

// Flies the drone at constant velocity v along +x from x0, holding height z: the reference moves
// with it, so the controller keeps the speed (an unyielding pilot).
void FlyStraight(World& world, double x0, double y, double z, double v, double duration) {
  world.SetReference([=](double t) {
    TrackingReference r;
    r.p_W = {x0 + v * t, y, z};
    r.v_W = {v, 0.0, 0.0};
    return r;
  });
  world.Advance(duration);
}

DroneState Moving(const DroneDescription& d, const Eigen::Vector3d& p, double v) {
  DroneState s = DroneState::Hover(d, p);
  s.v_W = {v, 0.0, 0.0};
  return s;
}

TEST(World, FreeFallMatchesHalfGTSquared) {
  const DroneDescription d = NoDrag();
  ObstacleSet set;
  set.ground = false;
  DroneState start;
  start.p_W = {0, 0, 100};
  World world(set, d, {}, start);  // rotors at 0 rpm
  world.StopMotors();
  const double t = 2.0;
  world.Advance(t);
  const double g = world.options().gravity;
  const double dt = 1.0 / world.options().physics_rate_hz;
  // Semi-implicit Euler falls g t dt / 2 further than the exact g t² / 2.
  const double drop = 100.0 - world.State().p_W.z();
  EXPECT_NEAR(drop, 0.5 * g * t * t, 0.5 * g * t * dt + 1e-3);
  EXPECT_NEAR(world.State().v_W.z(), -g * t, 1e-3);
  EXPECT_NEAR(world.State().p_W.head<2>().norm(), 0.0, 1e-9);
  EXPECT_EQ(world.collisions().Count(), 0u);
}

TEST(World, MotorsOffFallsToGroundAndCountsOneGroundEpisode) {
  const DroneDescription d;
  ObstacleSet set;  // ground only
  World world(set, d, {}, DroneState::Hover(d, {0, 0, 1}));
  world.StopMotors();
  world.Advance(3.0);
  EXPECT_NEAR(world.State().p_W.z(), d.collision_radius, 0.02);
  EXPECT_EQ(world.collisions().CountFor(ObstacleKind::kGround), 1u);
  EXPECT_EQ(world.collisions().CountObstacles(), 0u);
}

TEST(World, FlyingIntoCylinderCountsOneEpisode) {
  const DroneDescription d;
  ObstacleSet set;
  CylinderObstacle c;
  c.center_W = {3.0, 0.0};
  c.radius = 0.3;
  set.cylinders.push_back(c);
  set.cylinders.push_back({{3.0, 5.0}, 0.3, 0.0, 3.0});  // off the path
  World world(set, d, {}, Moving(d, {0, 0, 1.5}, 2.0));
  FlyStraight(world, 0.0, 0.0, 1.5, 2.0, 4.0);  // keeps pushing into the pillar
  const CollisionMonitor& m = world.collisions();
  EXPECT_EQ(m.CountFor({ObstacleKind::kCylinder, 0}), 1u);
  EXPECT_EQ(m.CountObstacles(), 1u);
  ASSERT_TRUE(m.FirstContactTime().has_value());
  // First contact when the sphere (r = 0.2) reaches the pillar's surface at x = 2.7.
  EXPECT_NEAR(*m.FirstContactTime(), (3.0 - 0.3 - 0.2) / 2.0, 0.05);
  EXPECT_LT(world.State().p_W.x(), 3.0 - 0.3 - 0.15);  // stopped by the pillar
}

TEST(World, PassThroughCountsCylinderOnceAndFliesOn) {
  const DroneDescription d;
  ObstacleSet set;
  set.cylinders.push_back({{3.0, 0.0}, 0.3, 0.0, 3.0});
  WorldOptions options;
  options.collision_response = CollisionResponse::kPassThrough;
  World world(set, d, options, Moving(d, {0, 0, 1.5}, 2.0));
  FlyStraight(world, 0.0, 0.0, 1.5, 2.0, 4.0);
  EXPECT_EQ(world.collisions().CountFor({ObstacleKind::kCylinder, 0}), 1u);
  EXPECT_EQ(world.collisions().Count(), 1u);
  EXPECT_GT(world.State().p_W.x(), 6.0);
}

ObstacleSet OneRing(double thickness) {
  ObstacleSet set;
  RingObstacle r;
  r.center_W = {4.0, 0.0, 2.0};
  r.yaw = 0.0;  // axis along +x: flying along x passes through the hole
  r.radius = 1.0;
  r.thickness = thickness;
  set.rings.push_back(r);
  return set;
}

TEST(World, ThroughRingHoleWithoutContact) {
  const DroneDescription d;
  World world(OneRing(0.1), d, {}, Moving(d, {0, 0, 2.0}, 2.0));
  FlyStraight(world, 0.0, 0.0, 2.0, 2.0, 4.0);
  EXPECT_EQ(world.collisions().Count(), 0u);
  EXPECT_GT(world.State().p_W.x(), 7.0);
}

TEST(World, IntoRingRimCountsOneEpisode) {
  const DroneDescription d;
  // Aim at the rim's upper centre line (z = 3): contact is certain.
  World world(OneRing(0.1), d, {}, Moving(d, {0, 0, 3.0}, 2.0));
  FlyStraight(world, 0.0, 0.0, 3.0, 2.0, 4.0);
  EXPECT_EQ(world.collisions().CountFor({ObstacleKind::kRing, 0}), 1u);
  EXPECT_EQ(world.collisions().Count(), 1u);
  ASSERT_TRUE(world.collisions().FirstContactTime().has_value());
  EXPECT_NEAR(*world.collisions().FirstContactTime(), (4.0 - 0.05 - 0.2) / 2.0, 0.05);
}

// No tunnelling: a 1 cm rim at the drone's top speed, for every shipped drone, with both
// collision responses and paths crossing the rim's centre line at several heights. Contact is
// counted exactly once, and with physical response the drone's centre never gets closer to the
// rim than its collision radius minus 2 cm (it is stopped or deflected, never passes through).
TEST(World, ThinRimAtTopSpeedIsNeverTunnelled) {
  const ObstacleSet set = OneRing(0.01);
  for (const char* name : {"research_1kg", "agile_small", "crazyflie"}) {
    const DroneDescription d =
        LoadDroneDescription(std::string(QUADTUNE_SOURCE_DIR) + "/assets/drones/" + name + ".yaml");
    for (CollisionResponse response : {CollisionResponse::kPhysical, CollisionResponse::kPassThrough}) {
      for (double z_offset : {0.0, 0.5 * d.collision_radius, -0.9 * d.collision_radius}) {
        WorldOptions options;
        options.collision_response = response;
        const double v = d.max_speed;
        const double z = 3.0 + z_offset;
        World world(set, d, options, Moving(d, {0, 0, z}, v));
        world.SetReference([=](double t) {
          TrackingReference r;
          r.p_W = {v * t, 0.0, z};
          r.v_W = {v, 0.0, 0.0};
          return r;
        });
        double min_clearance = 1e9;
        while (world.time() < 8.0 / v) {
          world.Step();
          min_clearance = std::min(min_clearance, SignedDistance(set.rings[0], world.State().p_W));
        }
        SCOPED_TRACE(std::string(name) + (response == CollisionResponse::kPhysical ? " physical" : " pass-through") +
                     " offset " + std::to_string(z_offset));
        EXPECT_EQ(world.collisions().CountFor({ObstacleKind::kRing, 0}), 1u);
        EXPECT_EQ(world.collisions().Count(), 1u);
        if (response == CollisionResponse::kPhysical) {
          EXPECT_GT(min_clearance, d.collision_radius - 0.02);
        } else {
          EXPECT_LT(min_clearance, d.collision_radius);  // it did fly through the rim
        }
      }
    }
  }
}

// Checks that every bit of two states is equal.
bool BitIdentical(const DroneState& a, const DroneState& b) {
  return std::memcmp(a.p_W.data(), b.p_W.data(), sizeof(double) * 3) == 0 &&
         std::memcmp(a.v_W.data(), b.v_W.data(), sizeof(double) * 3) == 0 &&
         std::memcmp(a.q_WB.coeffs().data(), b.q_WB.coeffs().data(), sizeof(double) * 4) == 0 &&
         std::memcmp(a.omega_B.data(), b.omega_B.data(), sizeof(double) * 3) == 0 &&
         a.rotor_speeds == b.rotor_speeds;
}

WorldOptions Noisy(std::uint64_t seed) {
  WorldOptions o;
  o.seed = seed;
  o.wind_W = {1.0, -0.5, 0.0};
  o.gust_stddev = 0.8;
  o.force_noise = 0.05;
  o.torque_noise = 1e-4;
  o.measurement_noise = {0.01, 0.02, 0.005, 0.01};
  o.mass_scale = 1.05;
  return o;
}

TrackingReference Figure(double t, double phase) {
  TrackingReference r;
  r.p_W = {10.0 + 3.0 * std::sin(0.5 * t + phase), 10.0 + 2.0 * std::sin(t), 2.0};
  r.v_W = {1.5 * std::cos(0.5 * t + phase), 2.0 * std::cos(t), 0.0};
  r.a_W = {-0.75 * std::sin(0.5 * t + phase), -2.0 * std::sin(t), 0.0};
  return r;
}

DroneState FlyTenSeconds(World& world, double phase) {
  world.SetReference([phase](double t) { return Figure(t, phase); });
  world.Advance(10.0);
  return world.State();
}

TEST(World, SameSeedGivesBitIdenticalFlight) {
  const DroneDescription d;
  const ObstacleSet set = testing::RandomForest(1, 60, 20, 20.0);
  const DroneState start = DroneState::Hover(d, {10, 10, 2});
  World a(set, d, Noisy(7), start), b(set, d, Noisy(7), start), c(set, d, Noisy(8), start);
  const DroneState sa = FlyTenSeconds(a, 0.0);
  EXPECT_TRUE(BitIdentical(sa, FlyTenSeconds(b, 0.0)));
  EXPECT_FALSE(BitIdentical(sa, FlyTenSeconds(c, 0.0)));
  EXPECT_EQ(a.collisions().Count(), b.collisions().Count());
}

TEST(World, ResetIsBitIdenticalToAFreshWorld) {
  const DroneDescription d;
  const ObstacleSet set1 = testing::RandomForest(1, 60, 20, 20.0);
  const ObstacleSet set2 = testing::RandomForest(2, 40, 30, 20.0);
  const DroneState start = DroneState::Hover(d, {10, 10, 2});
  World pooled(set1, d, Noisy(3), start);
  FlyTenSeconds(pooled, 0.3);
  // Same obstacles (kept), new seed.
  pooled.Reset(start, 4);
  World fresh(set1, d, Noisy(4), start);
  EXPECT_TRUE(BitIdentical(FlyTenSeconds(pooled, 0.0), FlyTenSeconds(fresh, 0.0)));
  // New obstacles and drone (rebuilt).
  const DroneDescription agile =
      LoadDroneDescription(std::string(QUADTUNE_SOURCE_DIR) + "/assets/drones/agile_small.yaml");
  const DroneState start2 = DroneState::Hover(agile, {10, 10, 2});
  pooled.Reset(set2, agile, Noisy(5), start2);
  World fresh2(set2, agile, Noisy(5), start2);
  EXPECT_EQ(pooled.time(), 0.0);
  EXPECT_EQ(pooled.collisions().Count(), 0u);
  EXPECT_TRUE(BitIdentical(FlyTenSeconds(pooled, 1.0), FlyTenSeconds(fresh2, 1.0)));
  EXPECT_EQ(pooled.collisions().Count(), fresh2.collisions().Count());
}

// 8 worlds stepping concurrently (sharing one ObstacleGeometry) give the same bits as 8 worlds
// with their own geometry one after another, at every thread count.
TEST(World, ConcurrentWorldsAreBitIdenticalAcrossThreadCounts) {
  const DroneDescription d;
  const ObstacleSet set = testing::RandomForest(1, 60, 20, 20.0);
  const DroneState start = DroneState::Hover(d, {10, 10, 2});
  constexpr int kWorlds = 8;
  std::vector<DroneState> reference;
  std::vector<std::size_t> reference_collisions;
  for (int i = 0; i < kWorlds; ++i) {
    World w(set, d, Noisy(100 + i), start);
    reference.push_back(FlyTenSeconds(w, 0.1 * i));
    reference_collisions.push_back(w.collisions().Count());
  }
  // The concurrent worlds share one obstacle geometry (read-only Bullet shapes).
  const auto geometry = ObstacleGeometry::Make(set, WorldOptions{});
  for (int threads : {1, 2, 4}) {
    std::vector<std::unique_ptr<World>> worlds;
    for (int i = 0; i < kWorlds; ++i) {
      worlds.push_back(std::make_unique<World>(geometry, d, Noisy(100 + i), start));
    }
    std::vector<DroneState> result(kWorlds);
    ParallelFor(threads, 0, kWorlds, [&](int i) {
      result[static_cast<std::size_t>(i)] = FlyTenSeconds(*worlds[static_cast<std::size_t>(i)], 0.1 * i);
    });
    for (int i = 0; i < kWorlds; ++i) {
      SCOPED_TRACE("threads " + std::to_string(threads) + " world " + std::to_string(i));
      EXPECT_TRUE(BitIdentical(result[static_cast<std::size_t>(i)], reference[static_cast<std::size_t>(i)]));
      EXPECT_EQ(worlds[static_cast<std::size_t>(i)]->collisions().Count(), reference_collisions[static_cast<std::size_t>(i)]);
    }
  }
}

TEST(World, ResetKeepsSharedGeometryAndRebuildsOnlyForNewLayouts) {
  const DroneDescription d;
  const ObstacleSet set1 = testing::RandomForest(1, 10, 5, 20.0);
  const DroneState start = DroneState::Hover(d, {10, 10, 2});
  World w(set1, d, {}, start);
  const ObstacleGeometry* first = w.geometry().get();
  w.Reset(set1, d, {}, start);
  EXPECT_EQ(w.geometry().get(), first);  // same layout: kept
  w.Reset(testing::RandomForest(2, 10, 5, 20.0), d, {}, start);
  EXPECT_NE(w.geometry().get(), first);  // new layout: rebuilt
  EXPECT_EQ(w.obstacles(), testing::RandomForest(2, 10, 5, 20.0));
  const auto shared = ObstacleGeometry::Make(set1, WorldOptions{});
  World a(shared, d, {}, start), b(shared, d, {}, start);
  EXPECT_EQ(a.geometry(), b.geometry());
  EXPECT_EQ(shared.use_count(), 3);
}

TEST(World, WindPushesDownwindAndHeavierDroneSags) {
  const DroneDescription d;
  ObstacleSet set;
  set.ground = false;
  WorldOptions windy;
  windy.wind_W = {3.0, 0.0, 0.0};
  World w(set, d, windy, DroneState::Hover(d, {0, 0, 2}));
  w.Advance(5.0);
  // Steady state of a PD loop under drag force D w: offset D w / (m kp).
  EXPECT_NEAR(w.State().p_W.x(), d.linear_drag.x() * 3.0 / (d.mass * d.gains.position.x()), 0.005);
  WorldOptions heavy;
  heavy.mass_scale = 1.2;
  World h(set, d, heavy, DroneState::Hover(d, {0, 0, 2}));
  h.Advance(5.0);
  // The controller's nominal-mass thrust leaves (m_true / m - 1) g / kp of sag.
  EXPECT_NEAR(h.State().p_W.z() - 2.0, -0.2 * kGravity / d.gains.position.z(), 0.005);
}

TEST(World, MeasuredStateCarriesNoiseOnlyWhenEnabled) {
  const DroneDescription d;
  ObstacleSet set;
  World clean(set, d, {}, DroneState::Hover(d, {0, 0, 2}));
  clean.Advance(0.1);
  WorldOptions o;
  o.measurement_noise.position = 0.05;
  World noisy(set, d, o, DroneState::Hover(d, {0, 0, 2}));
  noisy.Advance(0.1);
  const double clean_err = (clean.MeasuredState().p_W - clean.State().p_W).norm();
  const double noisy_err = (noisy.MeasuredState().p_W - noisy.State().p_W).norm();
  EXPECT_LT(clean_err, 0.01);  // sampled one controller period (2 ms) ago
  EXPECT_GT(noisy_err, 1e-3);
}

TEST(World, AdvanceCountsWholeStepsWithoutDrift) {
  const DroneDescription d;
  World w(ObstacleSet{}, d, {}, DroneState::Hover(d, {0, 0, 2}));
  for (int i = 0; i < 1000; ++i) w.Advance(0.0013);
  EXPECT_EQ(w.step_count(), 1300);
  EXPECT_DOUBLE_EQ(w.time(), 1.3);
}

TEST(World, RejectsBadOptions) {
  const DroneDescription d;
  WorldOptions o;
  o.controller_rate_hz = 300.0;  // does not divide 1000 Hz
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { World(ObstacleSet{}, d, o); }, "controller_rate_hz", {"must divide physics_rate_hz"}));
  o = {};
  o.physics_rate_hz = 50.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { World(ObstacleSet{}, d, o); },
                                                  "physics_rate_hz",
                                                  {"allowed: a number in [100, 20000]"}));
  o = {};
  o.mass_scale = 0.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { World(ObstacleSet{}, d, o); }, "mass_scale",
                                                  {"allowed: a number in [0.2, 5]"}));
  o = {};
  o.gust_stddev = -1.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { World(ObstacleSet{}, d, o); }, "gust_stddev", {"allowed: a number in [0, inf)"}));
  DroneDescription bad = d;
  bad.mass = -1.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { World(ObstacleSet{}, bad, {}); }, "mass",
                                                  {"allowed: a number in (0, inf)"}));
}

TEST(World, OptionsFromYamlNameNestedKeys) {
  const YamlMap map = YamlMap::FromString(
      "world:\n  physics_rate_hz: 2000\n  controller_rate_hz: 250\n  wind: [1, 2, 0]\n"
      "  measurement_noise: {position: 0.01}\n  collision_response: pass_through\n",
      "w.yaml");
  const WorldOptions o = WorldOptions::FromYaml(map.Map("world"));
  EXPECT_EQ(o.physics_rate_hz, 2000.0);
  EXPECT_EQ(o.collision_response, CollisionResponse::kPassThrough);
  EXPECT_EQ(o.measurement_noise.position, 0.01);
  try {
    WorldOptions::FromYaml(YamlMap::FromString("world: {gust_stddev: -2}", "w.yaml").Map("world"));
    ADD_FAILURE() << "no throw";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "world.gust_stddev");
    EXPECT_EQ(e.file(), "w.yaml");
  }
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { WorldOptions::FromYaml(YamlMap::FromString("physics_hz: 1", "w.yaml")); }, "physics_hz",
      {"unknown key; allowed keys"}));
}

TEST(World, OptionsWrittenByTheirFieldsReadBackEqual) {
  WorldOptions o;
  o.physics_rate_hz = 2000.0;
  o.controller_rate_hz = 250.0;
  o.gravity = 9.80665;
  o.collision_response = CollisionResponse::kPassThrough;
  o.collision_pool_size = 128;
  o.wind_W = {1.0 / 3.0, -2.0, 0.5};
  o.gust_stddev = 0.1 + 1e-12;
  o.measurement_noise.attitude = 0.01;
  o.measurement_noise.angular_velocity = 2.0 / 3.0;
  o.mass_scale = 1.1;
  o.motor_lag = false;
  o.seed = 123456789012345ULL;
  YAML::Emitter out;
  SetExactDoubles(out);
  WorldFields().Write(out, o);
  EXPECT_EQ(WorldOptions::FromYaml(YamlMap::FromString(out.c_str(), "w.yaml")), o);
}

TEST(World, EnumNamesAreTheFileSpellings) {
  EXPECT_STREQ(ToString(CollisionResponse::kPassThrough), "pass_through");
  EXPECT_EQ(FromString<CollisionResponse>("physical"), CollisionResponse::kPhysical);
  EXPECT_STREQ(ToString(ControlMode::kRotorSpeeds), "rotor_speeds");
  EXPECT_STREQ(ToString(ObstacleKind::kCylinder), "cylinders");
}

}  // namespace
}  // namespace quadtune::physics
