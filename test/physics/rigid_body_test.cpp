// Rigid-body dynamics of the simulated drone: torque-free motion against closed forms and a
// high-accuracy integration of Euler's equations, convergence in the physics step, and hover in
// a world with non-standard gravity.

#include <btBulletDynamicsCommon.h>
#include <gtest/gtest.h>

#include <cstdio>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>

#include "quadtune/physics/world.hpp"

namespace quadtune::physics {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

// A drone with no drag and rotors that may stop, so that nothing but the rigid body acts.
DroneDescription FreeBody(const Eigen::Vector3d& inertia) {
  DroneDescription d;
  d.inertia = inertia;
  d.linear_drag.setZero();
  d.min_rotor_speed = 0.0;
  return d;
}

Eigen::Quaterniond InitialAttitude() {
  return Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()) *
                            Eigen::AngleAxisd(0.3, Eigen::Vector3d(1.0, 2.0, 0.0).normalized()));
}

const Eigen::Vector3d kInitialRate_B(2.0, 0.0, 10.0);  // (rad/s)

// Spins the drone with motors off, far from any obstacle, in free fall (gravity acts at the
// centre of mass and exerts no torque), and returns the largest attitude error (rad) against
// `reference(t)` over `duration` seconds, sampled at every physics step.
double MaxAttitudeError(const DroneDescription& drone, double physics_rate_hz, double duration,
                        const std::function<Eigen::Quaterniond(double)>& reference) {
  ObstacleSet none;
  none.ground = false;
  WorldOptions options;
  options.physics_rate_hz = physics_rate_hz;
  options.controller_rate_hz = physics_rate_hz;
  DroneState start;
  start.p_W = {0.0, 0.0, 100.0};
  start.q_WB = InitialAttitude();
  start.omega_B = kInitialRate_B;
  World world(none, drone, options, start);
  world.StopMotors();
  double worst = 0.0;
  const auto steps = std::llround(duration * physics_rate_hz);
  for (long long i = 0; i < steps; ++i) {
    world.Step();
    worst = std::max(worst, world.State().q_WB.angularDistance(reference(world.time())));
  }
  EXPECT_FALSE(world.HasDiverged());
  return worst;
}

// Euler's equations J ω̇ = -ω × Jω with q̇ = q ⊗ (0, ω/2), integrated with classical RK4 in
// double precision at a step far below the physics step.
class EulerReference {
 public:
  EulerReference(const Eigen::Vector3d& inertia, const Eigen::Quaterniond& q0,
                 const Eigen::Vector3d& omega0_B)
      : inertia_(inertia) {
    x_ << q0.coeffs(), omega0_B;
  }

  // Attitude at time t (s); t must not decrease between calls.
  Eigen::Quaterniond At(double t) {
    while (time_ + 0.5 * kStep < t) {
      const double h = std::min(kStep, t - time_);
      const State k1 = Derivative(x_);
      const State k2 = Derivative(x_ + 0.5 * h * k1);
      const State k3 = Derivative(x_ + 0.5 * h * k2);
      const State k4 = Derivative(x_ + h * k3);
      x_ += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
      x_.head<4>().normalize();
      time_ += h;
    }
    return Eigen::Quaterniond(x_.head<4>());  // coeffs order x, y, z, w
  }

 private:
  using State = Eigen::Matrix<double, 7, 1>;
  static constexpr double kStep = 1e-5;  // (s)

  State Derivative(const State& x) const {
    const Eigen::Quaterniond q(x.head<4>());
    const Eigen::Vector3d w = x.tail<3>();
    const Eigen::Quaterniond dq =
        q * Eigen::Quaterniond(0.0, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z());
    State d;
    d << dq.coeffs(), (-w.cross(inertia_.cwiseProduct(w))).cwiseQuotient(inertia_);
    return d;
  }

  Eigen::Vector3d inertia_;
  State x_;
  double time_ = 0.0;
};

TEST(RigidBody, GyroscopicTermIsNotLeftToBullet) {
  const DroneDescription d;
  World world(ObstacleSet{}, d, {}, DroneState::Hover(d, {0, 0, 1}));
  EXPECT_EQ(world.bullet_body().getFlags() & (BT_ENABLE_GYROSCOPIC_FORCE_EXPLICIT |
                                              BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_WORLD |
                                              BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY),
            0);
}

// Axisymmetric body (J1 = J2): in the body frame the rate precesses about z at
// λ = (J3 - J1) / J1 · ω3, and the attitude is R(t) = Rot(L̂_W, |L| t / J1) R0 Rot(z, -λ t), with
// the angular momentum L constant in the world frame.
TEST(RigidBody, TorqueFreeAxisymmetricSpinMatchesClosedForm) {
  const DroneDescription d = FreeBody({2.64e-3, 2.64e-3, 4.96e-3});  // research_1kg
  const Eigen::Vector3d& J = d.inertia;
  const Eigen::Quaterniond q0 = InitialAttitude();
  const Eigen::Vector3d L_W = q0 * J.cwiseProduct(kInitialRate_B);
  const double lambda = (J.z() - J.x()) / J.x() * kInitialRate_B.z();
  const auto closed_form = [&](double t) {
    return Eigen::Quaterniond(Eigen::AngleAxisd(L_W.norm() / J.x() * t, L_W.normalized())) * q0 *
           Eigen::Quaterniond(Eigen::AngleAxisd(-lambda * t, Eigen::Vector3d::UnitZ()));
  };
  // The closed form itself solves Euler's equations (guards the reference, not the simulator).
  EulerReference euler(J, q0, kInitialRate_B);
  EXPECT_LT(euler.At(2.0).angularDistance(closed_form(2.0)), 1e-6);

  const double error = MaxAttitudeError(d, WorldOptions{}.physics_rate_hz, 2.0, closed_form);
  EXPECT_LT(error * kRadToDeg, 0.5);
}

TEST(RigidBody, TorqueFreeAsymmetricSpinMatchesEulerEquations) {
  // agile_small's inertia with the roll and pitch moments split apart (J1 < J2 < J3); the spin
  // is mostly about the major axis, so the motion is stable and the comparison meaningful.
  const DroneDescription d = FreeBody({0.8e-3, 1.2e-3, 1.8e-3});
  EulerReference euler(d.inertia, InitialAttitude(), kInitialRate_B);
  const double error = MaxAttitudeError(d, WorldOptions{}.physics_rate_hz, 2.0,
                                        [&](double t) { return euler.At(t); });
  EXPECT_LT(error * kRadToDeg, 0.5);
}

TEST(RigidBody, TorqueFreeErrorShrinksWithThePhysicsStep) {
  const DroneDescription d = FreeBody({0.8e-3, 1.2e-3, 1.8e-3});
  double previous = 0.0;
  for (double rate : {500.0, 1000.0, 2000.0}) {
    EulerReference euler(d.inertia, InitialAttitude(), kInitialRate_B);
    const double error = MaxAttitudeError(d, rate, 2.0, [&](double t) { return euler.At(t); });
    if (previous > 0.0) {
      // Halving the step must cut the error clearly (it converges; the midpoint rate makes the
      // rate update second order, Bullet's attitude update keeps a first-order part).
      EXPECT_GT(previous / error, 1.6) << "at " << rate << " Hz: " << error * kRadToDeg << " deg";
    }
    std::printf("torque-free spin, %.0f Hz: %.4f deg\n", rate, error * kRadToDeg);
    previous = error;
  }
}

class HoverInOtherGravity : public ::testing::TestWithParam<double> {};

TEST_P(HoverInOtherGravity, HoverRotorSpeedCarriesTheWeight) {
  const double g = GetParam();
  const DroneDescription d;
  const double w = d.HoverRotorSpeed(g);
  EXPECT_NEAR(4.0 * d.thrust_coefficient * w * w, d.mass * g, 1e-12);
}

TEST_P(HoverInOtherGravity, HoverStateHoldsAltitudeWithoutController) {
  WorldOptions options;
  options.gravity = GetParam();
  const DroneDescription d;
  ObstacleSet none;
  none.ground = false;
  const DroneState start = DroneState::Hover(d, {0.0, 0.0, 10.0}, 0.0, options.gravity);
  World world(none, d, options, start);
  world.CommandRotorSpeeds(start.rotor_speeds);
  world.Advance(2.0);
  EXPECT_NEAR(world.State().p_W.z(), 10.0, 0.01);
  EXPECT_NEAR(world.State().v_W.norm(), 0.0, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Gravity, HoverInOtherGravity, ::testing::Values(1.62, 3.71, 15.0));

}  // namespace
}  // namespace quadtune::physics
