#include "quadtune/physics/controller.hpp"

#include <algorithm>
#include <cmath>

namespace quadtune::physics {
namespace {

Eigen::Vector3d Vee(const Eigen::Matrix3d& m) { return {m(2, 1), m(0, 2), m(1, 0)}; }

}  // namespace

TrackingReference TrackingReference::Hold(const Eigen::Vector3d& p_W, double yaw) {
  TrackingReference r;
  r.p_W = p_W;
  r.yaw = yaw;
  return r;
}

GeometricController::GeometricController(const DroneDescription& drone, double max_tilt)
    : mass_(drone.mass),
      inertia_(drone.inertia),
      drag_(drone.linear_drag),
      gains_(drone.gains),
      max_tilt_(max_tilt),
      mixer_(drone) {}

ControlOutput GeometricController::Compute(const DroneState& state,
                                           const TrackingReference& reference) const {
  const Eigen::Matrix3d R = state.R_WB();
  const Eigen::Vector3d e_p = state.p_W - reference.p_W;
  const Eigen::Vector3d e_v = state.v_W - reference.v_W;

  // Desired acceleration including gravity compensation, limited in tilt.
  // Feed-forward of the linear drag at the reference velocity (still air assumed).
  const Eigen::Vector3d drag_ff_W = R * drag_.cwiseProduct(R.transpose() * reference.v_W) / mass_;
  Eigen::Vector3d a_cmd = -gains_.position.cwiseProduct(e_p) - gains_.velocity.cwiseProduct(e_v) +
                          reference.a_W + drag_ff_W + Eigen::Vector3d(0.0, 0.0, kGravity);
  a_cmd.z() = std::max(a_cmd.z(), 0.2 * kGravity);
  const double horizontal = a_cmd.head<2>().norm();
  const double max_horizontal = a_cmd.z() * std::tan(max_tilt_);
  if (horizontal > max_horizontal) a_cmd.head<2>() *= max_horizontal / horizontal;
  const Eigen::Vector3d force_W = mass_ * a_cmd;
  const double force_norm = force_W.norm();

  // Desired attitude from the thrust direction and the heading.
  const Eigen::Vector3d b3_d = force_W / force_norm;
  const Eigen::Vector3d b1_c(std::cos(reference.yaw), std::sin(reference.yaw), 0.0);
  Eigen::Vector3d b2_d = b3_d.cross(b1_c);
  const double b2_norm = b2_d.norm();
  b2_d = b2_norm > 1e-6 ? Eigen::Vector3d(b2_d / b2_norm) : Eigen::Vector3d(R.col(1));
  const Eigen::Vector3d b1_d = b2_d.cross(b3_d);
  Eigen::Matrix3d R_d;
  R_d.col(0) = b1_d;
  R_d.col(1) = b2_d;
  R_d.col(2) = b3_d;

  // Desired angular velocity (desired body frame) from the jerk feed-forward.
  const Eigen::Vector3d& j = reference.j_W;
  const Eigen::Vector3d h = (mass_ / force_norm) * (j - b3_d.dot(j) * b3_d);
  const Eigen::Vector3d omega_d(-h.dot(b2_d), h.dot(b1_d), reference.yaw_rate * b3_d.z());

  const Eigen::Vector3d e_R = 0.5 * Vee(R_d.transpose() * R - R.transpose() * R_d);
  const Eigen::Vector3d e_w = state.omega_B - R.transpose() * R_d * omega_d;
  const Eigen::Vector3d J_w = inertia_.cwiseProduct(state.omega_B);
  const Eigen::Vector3d alpha =
      -gains_.attitude.cwiseProduct(e_R) - gains_.angular_rate.cwiseProduct(e_w);

  ControlOutput out;
  out.wrench.thrust = std::max(0.0, force_W.dot(R.col(2)));
  out.wrench.moment_B = inertia_.cwiseProduct(alpha) + state.omega_B.cross(J_w);
  out.rotor_speeds = mixer_.RotorSpeedsFor(out.wrench, &out.saturated);
  out.q_WB_desired = Eigen::Quaterniond(R_d);
  return out;
}

}  // namespace quadtune::physics
