// The context policy (interpolation, refusal outside its range, YAML), the free-range
// measurement and the stopping risk, on hand-built maps.
#include "quadtune/engine/adaptation/context_policy.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "../config_error_util.hpp"
#include "../planning/scene_util.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::engine {
namespace {

using quadtune::test::ThrowsConfigError;

ContextPolicy ThreePoints() {
  ContextPolicy p;
  p.points = {{1.5, 2.0, "0.9"}, {3.0, 3.5, "2.1"}, {4.5, 5.0, "3.0"}};
  return p;
}

TEST(ContextPolicy, InterpolatesBetweenKnownPoints) {
  const ContextPolicy p = ThreePoints();
  EXPECT_DOUBLE_EQ(p.VDes(1.5), 2.0);
  EXPECT_DOUBLE_EQ(p.VDes(3.0), 3.5);
  EXPECT_DOUBLE_EQ(p.VDes(4.5), 5.0);
  EXPECT_DOUBLE_EQ(p.VDes(2.25), 2.75);  // halfway between the first two points
  EXPECT_DOUBLE_EQ(p.VDes(4.0), 3.5 + (4.0 - 3.0) / 1.5 * 1.5);
}

TEST(ContextPolicy, RefusesAContextOutsideItsRangeNamingIt) {
  const ContextPolicy p = ThreePoints();
  EXPECT_TRUE(ThrowsConfigError([&] { (void)p.VDes(1.2); }, "free_range",
                                {"1.2 m lies outside the policy's range [1.5, 4.5] m"}));
  EXPECT_TRUE(ThrowsConfigError([&] { (void)p.VDes(6.0); }, "free_range", {"extrapolate"}));
  EXPECT_DOUBLE_EQ(p.Clamp(6.0), 4.5);
  EXPECT_DOUBLE_EQ(p.Clamp(0.2), 1.5);
}

TEST(ContextPolicy, ValidateRefusesBadPoints) {
  ContextPolicy p = ThreePoints();
  p.points.resize(1);
  EXPECT_TRUE(ThrowsConfigError([&] { p.Validate("f.yaml"); }, "policy.points", {"two points"}));
  p = ThreePoints();
  p.points[2].free_range = 2.0;
  EXPECT_TRUE(ThrowsConfigError([&] { p.Validate("f.yaml"); }, "policy.points[2].free_range",
                                {"increase strictly"}));
  p = ThreePoints();
  p.points[0].v_des = 0.0;
  EXPECT_TRUE(
      ThrowsConfigError([&] { p.Validate("f.yaml"); }, "policy.points[0].v_des", {"(0, 15]"}));
}

TEST(ContextPolicy, YamlRoundTrips) {
  const ContextPolicy p = ThreePoints();
  const ContextPolicy back =
      ContextPolicy::FromYaml(YamlMap::FromString(p.ToYamlString(), "policy.yaml"));
  EXPECT_EQ(back, p);
  EXPECT_TRUE(ThrowsConfigError(
      [] {
        (void)ContextPolicy::FromYaml(
            YamlMap::FromString("points: [{free_range: 1, v_des: 2, speed: 3}]", "p.yaml"));
      },
      "points[0].speed", {"unknown key"}));
}

planning::LocalMap MapWithWallAt(double x_wall) {
  planning::LocalMapOptions o;
  o.size = Eigen::Vector3d(16.0, 16.0, 4.0);
  planning::LocalMap map(o, Eigen::Vector3d(4.0, 0.0, 1.2));
  const std::vector<Eigen::Vector3d> wall = planning::testing::WallPoints(x_wall, 6.0, 3.0);
  (void)map.Insert(Eigen::Vector3d(0.0, 0.0, 1.2), wall);
  return map;
}

TEST(FreeRange, ShortensAsAWallComesCloser) {
  FreeRangeOptions o;
  o.half_angle_deg = 0.0;
  o.rays = 1;
  const Eigen::Vector3d p(0.0, 0.0, 1.2);
  const double far = MeasureFreeRange(MapWithWallAt(4.0), p, Eigen::Vector3d::UnitX(), o);
  const double near = MeasureFreeRange(MapWithWallAt(2.0), p, Eigen::Vector3d::UnitX(), o);
  EXPECT_NEAR(far, 4.0, 0.15);
  EXPECT_NEAR(near, 2.0, 0.15);
  // Looking away from the wall: the full range.
  EXPECT_DOUBLE_EQ(MeasureFreeRange(MapWithWallAt(2.0), p, -Eigen::Vector3d::UnitX(), o), o.range);
}

// A straight constant-velocity trajectory along +x from the origin.
planning::Trajectory Line(double speed, double duration) {
  planning::Trajectory::Coefficients c = planning::Trajectory::Coefficients::Zero();
  c(2, 0) = 1.2;
  c(0, 1) = speed;
  return planning::Trajectory({duration}, {c});
}

TEST(StoppingRisk, ZeroWhenTheDroneCanStopAndGrowsWithSpeed) {
  const planning::LocalMap map = MapWithWallAt(6.0);
  // 2 m/s needs 0.67 m to stop at 3 m/s²; the wall is > 4 m ahead for the first second.
  EXPECT_DOUBLE_EQ(StoppingRisk(Line(2.0, 1.0), map, 3.0, 5.0), 0.0);
  // 5 m/s needs 4.2 m: at t = 0.5 s the drone is 3.5 m from the wall (minus inflation).
  const double fast = StoppingRisk(Line(5.0, 0.5), map, 3.0, 5.0);
  EXPECT_GT(fast, 0.0);
  EXPECT_GT(StoppingRisk(Line(6.0, 0.5), map, 3.0, 5.0), fast);
  // Clearance at speed: nothing near the line, so τ adds nothing far from the wall.
  EXPECT_DOUBLE_EQ(StoppingRisk(Line(1.0, 1.0), map, 3.0, 5.0, 0.3, 0.2), 0.0);
}

}  // namespace
}  // namespace quadtune::engine
