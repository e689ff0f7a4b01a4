#pragma once
/// \file
/// Quadrotor state and rotor models: the mixer between rotor speeds and the body wrench, and
/// the first-order motor lag.
///
/// Model (body frame B, forward-left-up): rotor i at position (x_i, y_i) in the body plane makes
/// thrust f_i = kf ω_i² along +z_B and drag torque s_i km ω_i² about z_B. The body wrench is
///   T = Σ f_i,  M_x = Σ y_i f_i,  M_y = -Σ x_i f_i,  M_z = Σ s_i km ω_i².
/// Rotor speeds ω are in rpm (see drone.hpp).
///
/// Thread safety: Mixer and MotorModel are immutable after construction; const calls are safe
/// from any thread. DroneState is a value.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>

#include "quadtune/physics/drone.hpp"

namespace quadtune::physics {

/// Speeds of the four rotors (rpm), in RotorLayout order.
using RotorSpeeds = std::array<double, 4>;

/// Full kinematic state of a quadrotor.
struct DroneState {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();              ///< centre of mass position (m)
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();              ///< velocity in W (m/s)
  Eigen::Quaterniond q_WB = Eigen::Quaterniond::Identity();   ///< attitude: rotates B into W
  Eigen::Vector3d omega_B = Eigen::Vector3d::Zero();          ///< angular velocity in B (rad/s)
  RotorSpeeds rotor_speeds = {0.0, 0.0, 0.0, 0.0};            ///< (rpm)

  /// Rotation matrix R_WB.
  [[nodiscard]] Eigen::Matrix3d R_WB() const { return q_WB.toRotationMatrix(); }
  /// Heading (rad): angle of the body x-axis projected on the xy-plane, from +x about +z.
  [[nodiscard]] double Yaw() const;

  /// A state at rest at p_W with heading `yaw` and the rotors spinning at the hover speed for
  /// `gravity` (m/s²; pass WorldOptions::gravity of the world the state starts in).
  static DroneState Hover(const DroneDescription& drone, const Eigen::Vector3d& p_W,
                          double yaw = 0.0, double gravity = kGravity);
};

/// Collective thrust along +z_B (N) and moments about the body axes (N·m).
struct BodyWrench {
  double thrust = 0.0;
  Eigen::Vector3d moment_B = Eigen::Vector3d::Zero();
};

/// Maps rotor speeds to the body wrench and back (allocation matrix and its inverse).
class Mixer {
 public:
  /// Builds the allocation matrix from the rotor layout and coefficients of `drone`.
  explicit Mixer(const DroneDescription& drone);

  /// Body wrench made by rotors spinning at `speeds` (rpm).
  [[nodiscard]] BodyWrench Wrench(const RotorSpeeds& speeds) const;

  /// Rotor speeds (rpm) that realise `wrench`, clamped to [min_rotor_speed, max_rotor_speed].
  /// When the request is not feasible the yaw moment is scaled down first (thrust, roll and pitch
  /// keep priority), then each squared speed is clamped. `saturated`, when given, reports
  /// whether anything had to be given up.
  [[nodiscard]] RotorSpeeds RotorSpeedsFor(const BodyWrench& wrench,
                                           bool* saturated = nullptr) const;

  /// The 4×4 matrix A with [T, M_x, M_y, M_z]ᵀ = A [ω_0², …, ω_3²]ᵀ (ω in rpm).
  [[nodiscard]] const Eigen::Matrix4d& allocation() const { return allocation_; }

 private:
  Eigen::Matrix4d allocation_;
  Eigen::Matrix4d inverse_;
  double min_speed_sq_;
  double max_speed_sq_;
};

/// First-order motor lag dω/dt = (ω_cmd - ω) / τ, integrated exactly over a fixed step.
class MotorModel {
 public:
  /// `dt` (s) is the integration step; with `enable_lag` false the rotors jump to the command.
  MotorModel(const DroneDescription& drone, double dt, bool enable_lag = true);

  /// Advances `speeds` (rpm) by one step towards `command` (rpm).
  void Step(const RotorSpeeds& command, RotorSpeeds& speeds) const;

  /// Fraction of the gap closed per step: 1 - exp(-dt / τ) (1 without lag).
  [[nodiscard]] double alpha() const { return alpha_; }

 private:
  double alpha_;
};

}  // namespace quadtune::physics
