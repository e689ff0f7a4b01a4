#include "quadtune/physics/quadrotor.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace quadtune::physics {
namespace {

TEST(Mixer, RoundTripsFeasibleWrench) {
  const DroneDescription d;
  const Mixer mixer(d);
  BodyWrench w;
  w.thrust = 12.0;
  w.moment_B = {0.05, -0.08, 0.01};
  bool saturated = true;
  const RotorSpeeds speeds = mixer.RotorSpeedsFor(w, &saturated);
  EXPECT_FALSE(saturated);
  const BodyWrench back = mixer.Wrench(speeds);
  EXPECT_NEAR(back.thrust, w.thrust, 1e-9);
  EXPECT_NEAR((back.moment_B - w.moment_B).norm(), 0.0, 1e-9);
}

TEST(Mixer, MomentSignsFollowRotorPositions) {
  const DroneDescription d;  // X configuration: rotor 0 front-left (+x, +y)
  const Mixer mixer(d);
  RotorSpeeds s;
  s.fill(20000.0);
  s[0] = 21000.0;
  const BodyWrench w = mixer.Wrench(s);
  EXPECT_GT(w.moment_B.x(), 0.0);  // more lift on +y rolls about +x
  EXPECT_LT(w.moment_B.y(), 0.0);  // more lift on +x pitches about -y
  EXPECT_LT(w.moment_B.z(), 0.0);  // rotor 0 has yaw torque sign -1
}

TEST(Mixer, ClampsToRotorLimitsAndGivesUpYawFirst) {
  const DroneDescription d;
  const Mixer mixer(d);
  BodyWrench w;
  w.thrust = 4.0 * d.thrust_coefficient * d.max_rotor_speed * d.max_rotor_speed * 0.9;
  w.moment_B = {0.0, 0.0, 0.5};  // far more yaw than the spare thrust allows
  bool saturated = false;
  const RotorSpeeds s = mixer.RotorSpeedsFor(w, &saturated);
  EXPECT_TRUE(saturated);
  for (double v : s) {
    EXPECT_GE(v, d.min_rotor_speed);
    EXPECT_LE(v, d.max_rotor_speed);
  }
  const BodyWrench back = mixer.Wrench(s);
  EXPECT_NEAR(back.thrust, w.thrust, 1e-6 * w.thrust);  // thrust kept
  EXPECT_GT(back.moment_B.z(), 0.0);                     // yaw reduced but same sign
  EXPECT_LT(back.moment_B.z(), 0.5);

  w.thrust = 1000.0;  // infeasible thrust: every rotor at max
  const RotorSpeeds full = mixer.RotorSpeedsFor(w, &saturated);
  EXPECT_TRUE(saturated);
  for (double v : full) EXPECT_DOUBLE_EQ(v, d.max_rotor_speed);
}

TEST(MotorModel, FirstOrderLagReachesSixtyThreePercentAfterOneTimeConstant) {
  const DroneDescription d;
  const double dt = 1e-3;
  const MotorModel motors(d, dt);
  RotorSpeeds speeds{};
  RotorSpeeds command;
  command.fill(10000.0);
  const int steps = static_cast<int>(std::lround(d.motor_time_constant / dt));
  for (int i = 0; i < steps; ++i) motors.Step(command, speeds);
  const double expected = 10000.0 * (1.0 - std::exp(-steps * dt / d.motor_time_constant));
  EXPECT_NEAR(speeds[0], expected, 1e-6);
  EXPECT_NEAR(speeds[3], 10000.0 * (1.0 - std::exp(-1.0)), 10000.0 * 0.01);

  const MotorModel instant(d, dt, /*enable_lag=*/false);
  RotorSpeeds s2{};
  instant.Step(command, s2);
  EXPECT_DOUBLE_EQ(s2[1], 10000.0);
}

TEST(DroneState, HoverHelperSetsHoverSpeedsAndYaw) {
  const DroneDescription d;
  const DroneState s = DroneState::Hover(d, {1, 2, 3}, 0.7);
  EXPECT_NEAR(s.Yaw(), 0.7, 1e-12);
  EXPECT_DOUBLE_EQ(s.rotor_speeds[2], d.HoverRotorSpeed());
  EXPECT_EQ(s.p_W, Eigen::Vector3d(1, 2, 3));
}

}  // namespace
}  // namespace quadtune::physics
