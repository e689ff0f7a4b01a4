#include "quadtune/physics/controller.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "quadtune/physics/world.hpp"

namespace quadtune::physics {
namespace {

ObstacleSet Empty() {
  ObstacleSet o;
  o.ground = false;
  return o;
}

TEST(Controller, HoverStateNeedsWeightAndNoMoment) {
  const DroneDescription d;
  const GeometricController controller(d);
  const DroneState s = DroneState::Hover(d, {0, 0, 1});
  const ControlOutput out = controller.Compute(s, TrackingReference::Hold({0, 0, 1}));
  EXPECT_NEAR(out.wrench.thrust, d.mass * kGravity, 1e-9);
  EXPECT_NEAR(out.wrench.moment_B.norm(), 0.0, 1e-12);
  EXPECT_FALSE(out.saturated);
  for (double w : out.rotor_speeds) EXPECT_NEAR(w, d.HoverRotorSpeed(), 1e-6);
}

TEST(Controller, HoversAtCommandedPointWithQuarterWeightPerRotor) {
  const DroneDescription d;
  World world(Empty(), d, {}, DroneState::Hover(d, {0, 0, 1.5}));
  const Eigen::Vector3d target(0.5, -0.3, 2.0);
  world.SetReference(TrackingReference::Hold(target, 0.3));
  world.Advance(8.0);
  const DroneState s = world.State();
  EXPECT_LT((s.p_W - target).norm(), 0.005);
  EXPECT_LT(s.v_W.norm(), 0.005);
  EXPECT_NEAR(s.Yaw(), 0.3, 1e-3);
  const double quarter_weight = d.mass * kGravity / 4.0;
  for (double w : s.rotor_speeds) {
    EXPECT_NEAR(d.thrust_coefficient * w * w, quarter_weight, 0.01 * quarter_weight);
  }
  // Position holds: one more second moves it by less than a millimetre.
  world.Advance(1.0);
  EXPECT_LT((world.State().p_W - s.p_W).norm(), 1e-3);
}

// Step response of the research drone to a 1 m step in x. Measured (see controller.hpp):
// overshoot 4.7 %, 2 % settling time 1.86 s.
TEST(Controller, StepResponseSettles) {
  const DroneDescription d;
  World world(Empty(), d, {}, DroneState::Hover(d, {0, 0, 2}));
  world.SetReference(TrackingReference::Hold({1.0, 0.0, 2.0}));
  double peak = 0.0;
  double settled_since = 0.0;
  double max_z_error = 0.0;
  const double dt = 0.002;
  for (int i = 1; i <= 3000; ++i) {  // 6 s
    world.Advance(dt);
    const DroneState s = world.State();
    peak = std::max(peak, s.p_W.x());
    max_z_error = std::max(max_z_error, std::abs(s.p_W.z() - 2.0));
    if (std::abs(s.p_W.x() - 1.0) > 0.02) settled_since = world.time();
  }
  const double overshoot = peak - 1.0;
  RecordProperty("overshoot_percent", std::to_string(100.0 * overshoot));
  RecordProperty("settling_time_2pct_s", std::to_string(settled_since));
  std::printf("step response: overshoot %.2f %%, 2%% settling time %.3f s, max |dz| %.4f m\n",
              100.0 * overshoot, settled_since, max_z_error);
  EXPECT_GT(overshoot, 0.0);
  EXPECT_LT(overshoot, 0.08);
  EXPECT_GT(settled_since, 1.0);
  EXPECT_LT(settled_since, 3.0);
  EXPECT_LT(max_z_error, 0.03);
  EXPECT_NEAR(world.State().p_W.x(), 1.0, 1e-3);
}

TrackingReference Circle(double t, double radius, double speed, double height) {
  const double w = speed / radius;
  const double c = std::cos(w * t);
  const double s = std::sin(w * t);
  TrackingReference r;
  r.p_W = {radius * c, radius * s, height};
  r.v_W = {-speed * s, speed * c, 0.0};
  r.a_W = {-speed * w * c, -speed * w * s, 0.0};
  r.j_W = {speed * w * w * s, -speed * w * w * c, 0.0};
  r.yaw = 0.0;
  return r;
}

// A 2 m/s circle of radius 2 m. Measured error (see controller.hpp): max 2.3 mm.
TEST(Controller, TracksCircle) {
  const DroneDescription d;
  DroneState start = DroneState::Hover(d, {2.0, 0.0, 2.0});
  start.v_W = {0.0, 2.0, 0.0};
  World world(Empty(), d, {}, start);
  world.SetReference([](double t) { return Circle(t, 2.0, 2.0, 2.0); });
  world.Advance(3.0);  // transient
  double max_error = 0.0;
  double sum_sq = 0.0;
  int n = 0;
  const double lap = 2.0 * std::numbers::pi * 2.0 / 2.0;
  while (world.time() < 3.0 + 2.0 * lap) {
    world.Advance(0.01);
    const double e = (world.State().p_W - Circle(world.time(), 2.0, 2.0, 2.0).p_W).norm();
    max_error = std::max(max_error, e);
    sum_sq += e * e;
    ++n;
  }
  const double rms = std::sqrt(sum_sq / n);
  RecordProperty("circle_max_error_m", std::to_string(max_error));
  RecordProperty("circle_rms_error_m", std::to_string(rms));
  std::printf("circle 2 m/s, r = 2 m: max error %.4f m, rms %.4f m\n", max_error, rms);
  EXPECT_LT(max_error, 0.01);
}

TEST(Controller, FollowsYawReference) {
  const DroneDescription d;
  World world(Empty(), d, {}, DroneState::Hover(d, {0, 0, 2}));
  world.SetReference(TrackingReference::Hold({0, 0, 2}, 1.5));
  world.Advance(3.0);
  EXPECT_NEAR(world.State().Yaw(), 1.5, 0.01);
  EXPECT_LT((world.State().p_W - Eigen::Vector3d(0, 0, 2)).norm(), 0.01);
}

TEST(Controller, LimitsTiltForLargeErrors) {
  const DroneDescription d;
  const GeometricController controller(d, /*max_tilt=*/0.5);
  const DroneState s = DroneState::Hover(d, {0, 0, 2});
  const ControlOutput out = controller.Compute(s, TrackingReference::Hold({100, 0, 2}));
  const Eigen::Vector3d b3 = out.q_WB_desired * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(std::acos(b3.z()), 0.5, 1e-9);
}

}  // namespace
}  // namespace quadtune::physics
