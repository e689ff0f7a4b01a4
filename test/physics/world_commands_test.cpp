// World's direct rotor commands, the controller's last output, and the divergence check: the
// paths a flight's failure handling and the low-level tests rely on.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "quadtune/physics/world.hpp"

namespace quadtune::physics {
namespace {

ObstacleSet Empty() {
  ObstacleSet set;
  set.ground = false;
  return set;
}

RotorSpeeds All(double rpm) { return {rpm, rpm, rpm, rpm}; }

// Hover speed on every rotor holds the drone up; more climbs, less sinks. The controller is out of
// the loop: the drone does not return to the reference it was holding.
TEST(WorldCommands, CommandRotorSpeedsBypassesTheController) {
  const DroneDescription d;
  const Eigen::Vector3d start(0, 0, 50);
  const double hover = d.HoverRotorSpeed();
  auto climb_after = [&](double rpm) {
    World world(Empty(), d, {}, DroneState::Hover(d, start));
    world.CommandRotorSpeeds(All(rpm));
    EXPECT_EQ(world.control_mode(), ControlMode::kRotorSpeeds);
    world.Advance(1.0);
    return world.State().p_W.z() - start.z();
  };
  EXPECT_NEAR(climb_after(hover), 0.0, 0.02);
  EXPECT_GT(climb_after(1.1 * hover), 0.5);   // 21% more thrust: ≈ 0.2 g for 1 s
  EXPECT_LT(climb_after(0.9 * hover), -0.5);  // 19% less
}

// Commands outside the rotor limits are clamped to them: far above the maximum flies exactly as
// the maximum, below the minimum as the minimum.
TEST(WorldCommands, CommandRotorSpeedsClampsToTheRotorLimits) {
  const DroneDescription d;
  auto state_after = [&](double rpm) {
    World world(Empty(), d, {}, DroneState::Hover(d, {0, 0, 50}));
    world.CommandRotorSpeeds(All(rpm));
    world.Advance(0.5);
    return world.State();
  };
  EXPECT_EQ(state_after(10.0 * d.max_rotor_speed).p_W, state_after(d.max_rotor_speed).p_W);
  EXPECT_EQ(state_after(0.0).p_W, state_after(d.min_rotor_speed).p_W);
  EXPECT_GT(state_after(d.max_rotor_speed).p_W.z(), state_after(d.HoverRotorSpeed()).p_W.z());
}

// Unequal speeds: a differential about the yaw axis turns the drone about z (reaction torques),
// with no tilt.
TEST(WorldCommands, UnequalRotorSpeedsYaw) {
  const DroneDescription d;
  const auto layout = RotorLayout(d);
  const double hover = d.HoverRotorSpeed();
  RotorSpeeds speeds{};
  for (std::size_t i = 0; i < 4; ++i) {
    speeds[i] = hover * (1.0 + 0.05 * layout[i].yaw_torque_sign);
  }
  World world(Empty(), d, {}, DroneState::Hover(d, {0, 0, 50}));
  world.CommandRotorSpeeds(speeds);
  world.Advance(0.5);
  const Eigen::Vector3d omega = world.State().omega_B;
  EXPECT_GT(std::abs(omega.z()), 0.1);
  EXPECT_LT(omega.head<2>().norm(), 0.05 * std::abs(omega.z()));
}

// While tracking, LastControl is the controller's latest output: hovering it asks about the hover
// speed of every rotor and a thrust of m g; handing control to direct commands keeps the mode.
TEST(WorldCommands, LastControlIsTheControllersOutput) {
  const DroneDescription d;
  World world(Empty(), d, {}, DroneState::Hover(d, {0, 0, 50}));
  world.Advance(0.5);
  EXPECT_EQ(world.control_mode(), ControlMode::kTracking);
  const ControlOutput& c = world.LastControl();
  for (double rpm : c.rotor_speeds)
    EXPECT_NEAR(rpm, d.HoverRotorSpeed(), 0.03 * d.HoverRotorSpeed());
  EXPECT_FALSE(c.saturated);
  // A reference 2 m up: the controller asks for more than hover thrust at first.
  TrackingReference up;
  up.p_W = {0, 0, 52};
  world.SetReference(up);
  world.Advance(0.05);
  for (double rpm : world.LastControl().rotor_speeds) EXPECT_GT(rpm, 1.02 * d.HoverRotorSpeed());
}

// The divergence check: a drone that leaves the 10 km box has diverged; just inside it has not.
TEST(WorldCommands, HasDivergedWhenTheDroneLeavesTheTenKilometreBox) {
  const DroneDescription d;
  DroneState s = DroneState::Hover(d, {0, 0, 9999.0});
  s.v_W = {0, 0, 5.0};
  World world(Empty(), d, {}, s);
  world.CommandRotorSpeeds(All(d.max_rotor_speed));
  EXPECT_FALSE(world.HasDiverged());
  world.Advance(0.1);  // still below 10 000 m
  EXPECT_FALSE(world.HasDiverged());
  world.Advance(1.0);
  EXPECT_GT(world.State().p_W.z(), 1e4);
  EXPECT_TRUE(world.HasDiverged());
}

}  // namespace
}  // namespace quadtune::physics
