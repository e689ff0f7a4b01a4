#include "quadtune/physics/quadrotor.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "quadtune/common/error.hpp"

namespace quadtune::physics {

double DroneState::Yaw() const {
  const Eigen::Vector3d x_W = q_WB * Eigen::Vector3d::UnitX();
  return std::atan2(x_W.y(), x_W.x());
}

DroneState DroneState::Hover(const DroneDescription& drone, const Eigen::Vector3d& p_W,
                             double yaw, double gravity) {
  DroneState s;
  s.p_W = p_W;
  s.q_WB = Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  s.rotor_speeds.fill(drone.HoverRotorSpeed(gravity));
  return s;
}

Mixer::Mixer(const DroneDescription& drone)
    : min_speed_sq_(drone.min_rotor_speed * drone.min_rotor_speed),
      max_speed_sq_(drone.max_rotor_speed * drone.max_rotor_speed) {
  const auto rotors = RotorLayout(drone);
  const double kf = drone.thrust_coefficient;
  const double km = drone.torque_coefficient;
  for (int i = 0; i < 4; ++i) {
    const RotorGeometry& r = rotors[static_cast<std::size_t>(i)];
    allocation_(0, i) = kf;
    allocation_(1, i) = kf * r.position_B.y();
    allocation_(2, i) = -kf * r.position_B.x();
    allocation_(3, i) = km * r.yaw_torque_sign;
  }
  Eigen::FullPivLU<Eigen::Matrix4d> lu(allocation_);
  QT_DEMAND(lu.isInvertible(), "rotor allocation matrix is singular");
  inverse_ = lu.inverse();
}

BodyWrench Mixer::Wrench(const RotorSpeeds& speeds) const {
  Eigen::Vector4d w2;
  for (int i = 0; i < 4; ++i) w2[i] = speeds[static_cast<std::size_t>(i)] * speeds[static_cast<std::size_t>(i)];
  const Eigen::Vector4d u = allocation_ * w2;
  return {u[0], u.tail<3>()};
}

RotorSpeeds Mixer::RotorSpeedsFor(const BodyWrench& wrench, bool* saturated) const {
  // Squared speeds without yaw moment, plus the yaw column scaled by the yaw moment.
  const Eigen::Vector4d base =
      inverse_.leftCols<3>() * Eigen::Vector3d(wrench.thrust, wrench.moment_B.x(), wrench.moment_B.y());
  const Eigen::Vector4d yaw = inverse_.col(3) * wrench.moment_B.z();
  double scale = 1.0;
  bool limited = false;
  for (int i = 0; i < 4; ++i) {
    const double b = base[i];
    if (b < min_speed_sq_ || b > max_speed_sq_) continue;  // yaw cannot rescue this rotor
    const double full = b + yaw[i];
    if (full > max_speed_sq_ && yaw[i] > 0.0) {
      scale = std::min(scale, (max_speed_sq_ - b) / yaw[i]);
    } else if (full < min_speed_sq_ && yaw[i] < 0.0) {
      scale = std::min(scale, (min_speed_sq_ - b) / yaw[i]);
    }
  }
  if (scale < 1.0) limited = true;
  const Eigen::Vector4d w2 = base + scale * yaw;
  RotorSpeeds speeds{};
  for (int i = 0; i < 4; ++i) {
    const double clamped = std::clamp(w2[i], min_speed_sq_, max_speed_sq_);
    if (clamped != w2[i]) limited = true;
    speeds[static_cast<std::size_t>(i)] = std::sqrt(clamped);
  }
  if (saturated != nullptr) *saturated = limited;
  return speeds;
}

MotorModel::MotorModel(const DroneDescription& drone, double dt, bool enable_lag)
    : alpha_(enable_lag ? 1.0 - std::exp(-dt / drone.motor_time_constant) : 1.0) {}

void MotorModel::Step(const RotorSpeeds& command, RotorSpeeds& speeds) const {
  for (std::size_t i = 0; i < 4; ++i) speeds[i] += alpha_ * (command[i] - speeds[i]);
}

}  // namespace quadtune::physics
