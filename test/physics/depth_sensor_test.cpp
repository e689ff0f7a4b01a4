#include "quadtune/physics/depth_sensor.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "../config_error_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/physics/world.hpp"

namespace quadtune::physics {
namespace {

// Independent closed form: distance from o along unit d (horizontal part only matters for an
// infinitely tall cylinder) to a vertical cylinder's side.
double SideDistance(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector2d& c,
                    double r) {
  const Eigen::Vector2d d2 = d.head<2>();
  const Eigen::Vector2d oc = c - o.head<2>();
  const double a = d2.squaredNorm();
  const double b = oc.dot(d2);
  const double disc = b * b - a * (oc.squaredNorm() - r * r);
  if (disc < 0.0) return std::numeric_limits<double>::infinity();
  return (b - std::sqrt(disc)) / a;
}

TEST(DepthSensor, RangesMatchAnalyticCylinderWithinOneMillimetre) {
  ObstacleSet set;
  set.ground = false;
  CylinderObstacle c;
  c.center_W = {3.0, 0.4};
  c.radius = 1.0;
  c.z_min = -50.0;
  c.z_max = 50.0;
  set.cylinders.push_back(c);
  DepthSensorOptions options;
  options.width = 32;
  options.height = 24;
  DepthSensor sensor(options);
  DepthScan scan;
  const Eigen::Vector3d p_WB(0.0, 0.0, 1.0);
  const Eigen::Quaterniond q_WB(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()));
  sensor.Scan(RayCaster(set), p_WB, q_WB, 0.0, scan);
  ASSERT_EQ(scan.ranges.size(), 32u * 24u);
  int hits = 0;
  for (std::size_t i = 0; i < scan.ranges.size(); ++i) {
    const Eigen::Vector3d d_W = q_WB * sensor.directions_C()[i];
    const double expected = SideDistance(p_WB, d_W, c.center_W, c.radius);
    if (expected <= options.max_range) {
      ++hits;
      EXPECT_NEAR(scan.ranges[i], expected, 1e-3) << "pixel " << i;
    } else {
      EXPECT_TRUE(std::isinf(scan.ranges[i]));
    }
  }
  EXPECT_GT(hits, 100);
  EXPECT_EQ(scan.hits_W.size(), static_cast<std::size_t>(hits));
  EXPECT_EQ(scan.hits_W.size() + scan.misses_W.size(), scan.ranges.size());
  for (const auto& p : scan.hits_W) EXPECT_NEAR(SignedDistance(c, p), 0.0, 1e-6);
  for (const auto& p : scan.misses_W) EXPECT_NEAR((p - scan.origin_W).norm(), options.max_range, 1e-9);
}

TEST(DepthSensor, NearerObstacleOccludesFarther) {
  ObstacleSet set;
  set.ground = false;
  CylinderObstacle near_c, far_c;
  near_c.center_W = {2.0, 0.0};
  near_c.radius = 0.3;
  far_c.center_W = {4.0, 0.0};
  far_c.radius = 1.0;
  near_c.z_min = far_c.z_min = -10;
  near_c.z_max = far_c.z_max = 10;
  set.cylinders = {near_c, far_c};
  DepthSensorOptions options;
  options.width = 1;
  options.height = 1;
  DepthSensor sensor(options);
  DepthScan scan;
  sensor.Scan(RayCaster(set), {0, 0, 1}, Eigen::Quaterniond::Identity(), 0.0, scan);
  ASSERT_EQ(scan.hits_W.size(), 1u);
  EXPECT_NEAR(scan.ranges[0], 1.7, 1e-6);
}

TEST(DepthSensor, PitchedCameraSeesGroundAtSlantRange) {
  ObstacleSet set;  // ground only
  DepthSensorOptions options;
  options.width = 1;
  options.height = 1;
  options.pitch = std::numbers::pi / 6.0;  // 30° down
  options.max_range = 10.0;
  DepthSensor sensor(options);
  DepthScan scan;
  sensor.Scan(RayCaster(set), {0, 0, 2}, Eigen::Quaterniond::Identity(), 0.0, scan);
  EXPECT_NEAR(scan.ranges[0], 2.0 / std::sin(std::numbers::pi / 6.0), 1e-9);
}

TEST(DepthSensor, EmptyWorldGivesOnlyFlaggedMisses) {
  ObstacleSet set;
  set.ground = false;
  DepthSensor sensor;
  DepthScan scan;
  sensor.Scan(RayCaster(set), {0, 0, 1}, Eigen::Quaterniond::Identity(), 2.5, scan);
  EXPECT_TRUE(scan.hits_W.empty());
  EXPECT_EQ(scan.misses_W.size(), 64u * 48u);
  EXPECT_DOUBLE_EQ(scan.time, 2.5);
}

TEST(DepthSensor, FieldOfViewSpansConfiguredAngles) {
  DepthSensorOptions options;
  options.width = 101;
  options.height = 1;
  options.horizontal_fov_deg = 90.0;
  DepthSensor sensor(options);
  const Eigen::Vector3d& left = sensor.directions_C().front();
  // Pixel centres: the outermost lies half a pixel inside the 45° edge.
  const double expected = std::atan((50.0 / 50.5) * std::tan(std::numbers::pi / 4.0));
  EXPECT_NEAR(std::atan2(left.y(), left.x()), expected, 1e-12);
}

TEST(DepthSensor, UpdateScansAtTheConfiguredRate) {
  const DroneDescription drone;
  ObstacleSet set;
  World world(set, drone, {}, DroneState::Hover(drone, {0, 0, 2}));
  DepthSensorOptions options;
  options.rate_hz = 15.0;
  options.width = 8;
  options.height = 6;
  DepthSensor sensor(options);
  DepthScan scan;
  int scans = 0;
  while (world.time() < 1.0 - 1e-9) {
    if (sensor.Update(world, scan)) ++scans;
    world.Step();
  }
  EXPECT_EQ(scans, 15);
}

TEST(DepthSensor, NoiseIsSeeded) {
  ObstacleSet set;
  DepthSensorOptions options;
  options.range_noise = 0.01;
  options.pitch = 0.5;
  DepthSensor a(options, 42), b(options, 42), c(options, 43);
  DepthScan sa, sb, sc;
  const RayCaster caster(set);
  a.Scan(caster, {0, 0, 2}, Eigen::Quaterniond::Identity(), 0.0, sa);
  b.Scan(caster, {0, 0, 2}, Eigen::Quaterniond::Identity(), 0.0, sb);
  c.Scan(caster, {0, 0, 2}, Eigen::Quaterniond::Identity(), 0.0, sc);
  EXPECT_EQ(sa.ranges, sb.ranges);
  EXPECT_NE(sa.ranges, sc.ranges);
}

TEST(DepthSensor, RejectsBadOptions) {
  DepthSensorOptions o;
  o.max_range = 0.05;  // below min_range
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { DepthSensor{o}; }, "max_range",
                                                  {"allowed: a number in (0.1, inf)"}));
  o = {};
  o.horizontal_fov_deg = 180.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { DepthSensor{o}; }, "horizontal_fov_deg",
                                                  {"allowed: a number in (0, 170]"}));
  o = {};
  o.width = 0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { DepthSensor{o}; }, "width",
                                                  {"allowed: an integer in [1, 4096]"}));
  o = {};
  o.rate_hz = 0.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { DepthSensor{o}; }, "rate_hz",
                                                  {"allowed: a number in (0, inf)"}));
}

}  // namespace
}  // namespace quadtune::physics
