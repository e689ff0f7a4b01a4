#pragma once
/// \file
/// Immutable description of a quadrotor: rigid body, rotors, aerodynamic drag, collision shape
/// and tracking-controller gains. Loaded from YAML files in assets/drones/.
///
/// Units: SI throughout, except rotor speeds, which are in revolutions per minute (rpm), so the
/// thrust and torque coefficients are per rpm² (the Crazyflie literature's convention).
/// Frames: body frame B is forward-left-up (x forward, z up along the collective thrust).
///
/// Thread safety: a DroneDescription is a value; share it read-only between threads.

#include <Eigen/Core>
#include <array>
#include <string>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/fields_fwd.hpp"

namespace quadtune::physics {

/// Standard gravity used by the physics module (m/s²).
inline constexpr double kGravity = 9.81;

/// Rotor arrangement in the body xy-plane.
enum class RotorConfiguration {
  kX,     ///< rotors at ±45°, ±135° from the body x-axis
  kPlus,  ///< rotors on the body axes (0°, 90°, 180°, 270°)
};
constexpr auto EnumNames(RotorConfiguration) {
  return std::array{EnumName{RotorConfiguration::kX, "x"},
                    EnumName{RotorConfiguration::kPlus, "plus"}};
}

/// Shape of the drone body used for collisions.
enum class CollisionShapeKind {
  kSphere,  ///< a sphere of `collision_radius` centred on the centre of mass
  kBox,     ///< a box with `collision_half_extents` (body frame) centred on the centre of mass
};
constexpr auto EnumNames(CollisionShapeKind) {
  return std::array{EnumName{CollisionShapeKind::kSphere, "sphere"},
                    EnumName{CollisionShapeKind::kBox, "box"}};
}

/// Gains of the geometric SE(3) tracking controller (Lee, Leok, McClamroch 2010). Position and
/// velocity gains are normalised by the mass, attitude and rate gains by the inertia, so they
/// carry over between drones of different size:
///   F_W = m (-kp ∘ e_p - kv ∘ e_v + a_ref + g e_z),  M_B = J (-kR ∘ e_R - kw ∘ e_w) + w × J w.
struct ControllerGains {
  Eigen::Vector3d position = {5.7, 5.7, 6.2};            ///< kp (1/s²), world x, y, z
  Eigen::Vector3d velocity = {3.4, 3.4, 4.0};            ///< kv (1/s), world x, y, z
  Eigen::Vector3d attitude = {150.0, 150.0, 40.0};       ///< kR (1/s²), body x, y, z
  Eigen::Vector3d angular_rate = {22.0, 22.0, 12.0};     ///< kw (1/s), body x, y, z

  friend bool operator==(const ControllerGains&, const ControllerGains&) = default;
};

/// Everything the physics needs to know about one quadrotor. Defaults describe the ~1 kg
/// EGO-Planner research drone (assets/drones/research_1kg.yaml).
struct DroneDescription {
  std::string name = "research_1kg";
  double mass = 0.98;                                          ///< (kg), > 0
  Eigen::Vector3d inertia = {2.64e-3, 2.64e-3, 4.96e-3};       ///< principal inertia, body (kg·m²)
  double arm_length = 0.26;                    ///< centre of mass to rotor axis (m), > 0
  RotorConfiguration configuration = RotorConfiguration::kX;
  double min_rotor_speed = 1200.0;             ///< (rpm), >= 0, < max_rotor_speed
  double max_rotor_speed = 35000.0;            ///< (rpm)
  double thrust_coefficient = 5.5e-9;          ///< kf: thrust per rotor = kf ω² (N/rpm²), > 0
  double torque_coefficient = 1.1e-10;         ///< km: drag torque per rotor = km ω² (N·m/rpm²), > 0
  double motor_time_constant = 1.0 / 30.0;     ///< first-order motor lag (s), > 0
  Eigen::Vector3d linear_drag = {0.1, 0.1, 0.15};  ///< drag force = -D v_air, body axes (N·s/m), >= 0
  CollisionShapeKind collision_shape = CollisionShapeKind::kSphere;
  double collision_radius = 0.2;               ///< sphere radius (m), > 0 (used for kSphere)
  Eigen::Vector3d collision_half_extents = {0.2, 0.2, 0.05};  ///< box half sizes (m) (kBox)
  double max_speed = 10.0;                     ///< top flight speed the world must handle (m/s)
  ControllerGains gains;

  /// Thrust of all four rotors at max_rotor_speed divided by the weight m g.
  [[nodiscard]] double ThrustToWeight() const;
  /// Rotor speed (rpm) at which the four rotors together carry the weight m g, for gravity
  /// `gravity` (m/s², > 0; pass WorldOptions::gravity of the world the drone flies in).
  [[nodiscard]] double HoverRotorSpeed(double gravity = kGravity) const;
  /// Radius (m) of the smallest sphere about the centre of mass containing the collision shape.
  [[nodiscard]] double BoundingRadius() const;
  /// Radius (m) of the largest sphere about the centre of mass inside the collision shape.
  [[nodiscard]] double InscribedRadius() const;

  /// Throws ConfigError(origin, key, ...) naming the first bad field and its allowed range.
  /// Checks: finite positive mass, inertia, arm, coefficients, time constant and collision size;
  /// 0 <= min_rotor_speed < max_rotor_speed; thrust-to-weight > 1 at max_rotor_speed and < 1 at
  /// min_rotor_speed (so the drone can both climb and descend); non-negative drag; positive gains
  /// and max_speed. `key_prefix` is prepended to key names (for descriptions nested in a file).
  void Validate(const std::string& origin = "", const std::string& key_prefix = "") const;

  /// Reads the keys of DroneFields() (example: assets/drones/research_1kg.yaml), then
  /// Validate()s. Every key is required except `name`, `drag`, `max_speed` and `controller`
  /// (defaults above); unknown keys are rejected. Errors name the file and the dotted key.
  static DroneDescription FromYaml(const YamlMap& map);

  friend bool operator==(const DroneDescription&, const DroneDescription&) = default;
};

/// The keys of a drone description file: reading, writing and the configuration reference.
const Fields<DroneDescription>& DroneFields();
/// The keys of its `rotor` map (members of DroneDescription: min_rotor_speed, ...).
const Fields<DroneDescription>& RotorFields();
/// The keys of its `collision` map with `shape: sphere`.
const Fields<DroneDescription>& SphereCollisionFields();
/// The keys of its `collision` map with `shape: box`.
const Fields<DroneDescription>& BoxCollisionFields();
/// The keys of its `controller` map.
const Fields<ControllerGains>& ControllerFields();

/// Loads and validates a drone description file. Throws ConfigError naming the file and key.
[[nodiscard]] DroneDescription LoadDroneDescription(const std::string& path);

/// Unit-free geometry of one rotor: position in the body plane and the sign of its drag torque
/// about body z (+1: the rotor spins clockwise seen from above, pushing the body counter-clockwise).
struct RotorGeometry {
  Eigen::Vector2d position_B = Eigen::Vector2d::Zero();  ///< (m)
  double yaw_torque_sign = 1.0;
};

/// The four rotors of a description. Rotor i sits at angle θ_i = 45° + 90° i (X) or 90° i (+),
/// counter-clockwise from body x; yaw torque signs alternate, starting with -1 for rotor 0.
[[nodiscard]] std::array<RotorGeometry, 4> RotorLayout(const DroneDescription& drone);

}  // namespace quadtune::physics
