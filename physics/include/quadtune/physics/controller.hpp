#pragma once
/// \file
/// Geometric tracking controller on SE(3) (T. Lee, M. Leok, N. H. McClamroch, "Geometric
/// tracking control of a quadrotor UAV on SE(3)", CDC 2010), with the reference's jerk fed
/// forward into the desired angular velocity (differential flatness, Mellinger & Kumar 2011).
///
/// Per update, with e_p = p - p_ref, e_v = v - v_ref (world frame):
///   F_W   = m (-kp ∘ e_p - kv ∘ e_v + a_ref + g e_z) + R D Rᵀ v_ref   (desired force with drag
///           feed-forward, tilt-limited; D = the description's linear drag)
///   b3_d  = F_W / |F_W|,  b2_d = (b3_d × b1_c) / |…|,  b1_d = b2_d × b3_d,  b1_c = (cos ψ, sin ψ, 0)
///   T     = F_W · b3  (projection on the current thrust axis)
///   e_R   = ½ (R_dᵀ R - Rᵀ R_d)^∨,  e_w = w_B - Rᵀ R_d w_d
///   M_B   = J (-kR ∘ e_R - kw ∘ e_w) + w_B × J w_B
///   w_d   from jerk: h = m/|F| (j - (b3_d·j) b3_d),  w_d = (-h·b2_d, h·b1_d, ψ̇ e_z·b3_d)
/// then rotor speeds through Mixer::RotorSpeedsFor (clamped to the rotor limits).
///
/// The step response (a 1 m step in x from hover) and the tracking of a 2 m/s circle of
/// radius 2 m with acceleration, jerk and drag feed-forward, at the default gains, are in
/// docs/design.md, "The controller" (the tests Controller.StepResponseSettles and
/// Controller.TracksCircle print the figures; research_1kg.yaml, 1000 Hz physics, 500 Hz
/// control, motor lag 1/30 s).
/// There is no integral term: a constant unmodelled force F leaves a steady offset F / (m kp)
/// (e.g. wind, or WorldOptions::mass_scale).
///
/// Thread safety: immutable after construction; Compute() is const and safe from any thread.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/quadrotor.hpp"

namespace quadtune::physics {

/// What the vehicle should do now: a flat-output reference (world frame W).
struct TrackingReference {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  ///< position (m)
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();  ///< velocity (m/s)
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();  ///< acceleration (m/s²)
  Eigen::Vector3d j_W = Eigen::Vector3d::Zero();  ///< jerk (m/s³); zero when unknown
  double yaw = 0.0;                               ///< heading (rad)
  double yaw_rate = 0.0;                          ///< (rad/s)

  /// Hold position p_W with heading yaw.
  static TrackingReference Hold(const Eigen::Vector3d& p_W, double yaw = 0.0);
};

/// One controller update's result.
struct ControlOutput {
  BodyWrench wrench;                                                ///< requested wrench
  RotorSpeeds rotor_speeds = {0.0, 0.0, 0.0, 0.0};                  ///< command (rpm), clamped
  Eigen::Quaterniond q_WB_desired = Eigen::Quaterniond::Identity();  ///< desired attitude
  bool saturated = false;  ///< the mixer had to clamp or give up yaw authority
};

/// The geometric controller. Gains, mass and inertia come from the (nominal) description, so a
/// world whose true mass differs (WorldOptions::mass_scale) shows the effect of model mismatch.
class GeometricController {
 public:
  /// `max_tilt` (rad) bounds the angle between the desired thrust axis and +z_W.
  explicit GeometricController(const DroneDescription& drone, double max_tilt = 1.0);

  /// Computes the wrench and rotor-speed command for the (measured) `state`.
  [[nodiscard]] ControlOutput Compute(const DroneState& state,
                                      const TrackingReference& reference) const;

  [[nodiscard]] const Mixer& mixer() const { return mixer_; }

 private:
  double mass_;
  Eigen::Vector3d inertia_;
  Eigen::Vector3d drag_;
  ControllerGains gains_;
  double max_tilt_;
  Mixer mixer_;
};

}  // namespace quadtune::physics
