#include "quadtune/physics/drone.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::physics {
namespace {

void CheckPositiveVector(const Eigen::Vector3d& v, const std::string& origin,
                         const std::string& key, bool allow_zero = false) {
  for (int i = 0; i < 3; ++i) {
    CheckInRange(v[i], allow_zero ? Range::NonNegative() : Range::Positive(), origin,
                 key + "[" + std::to_string(i) + "]");
  }
}

}  // namespace

double DroneDescription::ThrustToWeight() const {
  return 4.0 * thrust_coefficient * max_rotor_speed * max_rotor_speed / (mass * kGravity);
}

double DroneDescription::HoverRotorSpeed(double gravity) const {
  return std::sqrt(mass * gravity / (4.0 * thrust_coefficient));
}

double DroneDescription::BoundingRadius() const {
  return collision_shape == CollisionShapeKind::kSphere ? collision_radius
                                                        : collision_half_extents.norm();
}

double DroneDescription::InscribedRadius() const {
  return collision_shape == CollisionShapeKind::kSphere ? collision_radius
                                                        : collision_half_extents.minCoeff();
}

void DroneDescription::Validate(const std::string& origin, const std::string& key_prefix) const {
  const auto K = [&key_prefix](const char* key) { return key_prefix + key; };
  CheckInRange(mass, Range::Positive(), origin, K("mass"));
  CheckPositiveVector(inertia, origin, K("inertia"));
  // A rigid body's principal moments obey the triangle inequality.
  for (int i = 0; i < 3; ++i) {
    const double others = inertia[(i + 1) % 3] + inertia[(i + 2) % 3];
    if (inertia[i] > others * (1.0 + 1e-9)) {
      std::ostringstream s;
      s << "principal moments violate the triangle inequality: I[" << i << "] = " << inertia[i]
        << " > " << others << " (sum of the other two)";
      throw ConfigError(origin, K("inertia"), s.str());
    }
  }
  CheckInRange(arm_length, Range::Positive(), origin, K("arm_length"));
  CheckInRange(min_rotor_speed, Range::NonNegative(), origin, K("rotor.min_speed_rpm"));
  CheckInRange(max_rotor_speed,
               {min_rotor_speed, std::numeric_limits<double>::infinity(), true, false}, origin,
               K("rotor.max_speed_rpm"));
  CheckInRange(thrust_coefficient, Range::Positive(), origin, K("rotor.thrust_coefficient"));
  CheckInRange(torque_coefficient, Range::Positive(), origin, K("rotor.torque_coefficient"));
  CheckInRange(motor_time_constant, Range::Positive(), origin, K("rotor.time_constant"));
  if (!(ThrustToWeight() > 1.0)) {
    std::ostringstream s;
    s << "thrust-to-weight ratio at max_speed_rpm is " << ThrustToWeight()
      << "; it must exceed 1 (4 kf max_speed_rpm² > mass g)";
    throw ConfigError(origin, K("rotor.thrust_coefficient"), s.str());
  }
  const double min_twr =
      4.0 * thrust_coefficient * min_rotor_speed * min_rotor_speed / (mass * kGravity);
  if (!(min_twr < 1.0)) {
    std::ostringstream s;
    s << "thrust-to-weight ratio at min_speed_rpm is " << min_twr
      << "; it must stay below 1 so the drone can descend";
    throw ConfigError(origin, K("rotor.min_speed_rpm"), s.str());
  }
  CheckPositiveVector(linear_drag, origin, K("drag"), /*allow_zero=*/true);
  if (collision_shape == CollisionShapeKind::kSphere) {
    CheckInRange(collision_radius, Range::Positive(), origin, K("collision.radius"));
  } else {
    CheckPositiveVector(collision_half_extents, origin, K("collision.half_extents"));
  }
  CheckInRange(max_speed, Range::Positive(), origin, K("max_speed"));
  CheckPositiveVector(gains.position, origin, K("controller.position_gain"));
  CheckPositiveVector(gains.velocity, origin, K("controller.velocity_gain"));
  CheckPositiveVector(gains.attitude, origin, K("controller.attitude_gain"));
  CheckPositiveVector(gains.angular_rate, origin, K("controller.angular_rate_gain"));
}

DroneDescription DroneDescription::FromYaml(const YamlMap& map) {
  map.RejectUnknownKeys({"name", "mass", "inertia", "arm_length", "configuration", "rotor", "drag",
                         "collision", "max_speed", "controller"});
  DroneDescription d;
  const std::string& file = map.file();
  d.name = map.String("name", d.name);
  d.mass = map.Number("mass", std::nullopt, Range::Positive());
  d.inertia = map.Vector3("inertia");
  d.arm_length = map.Number("arm_length", std::nullopt, Range::Positive());
  const std::string config = map.String("configuration", std::nullopt, {"x", "plus"});
  d.configuration = config == "x" ? RotorConfiguration::kX : RotorConfiguration::kPlus;

  const YamlMap rotor = map.Map("rotor");
  rotor.RejectUnknownKeys({"min_speed_rpm", "max_speed_rpm", "thrust_coefficient",
                           "torque_coefficient", "time_constant"});
  d.min_rotor_speed = rotor.Number("min_speed_rpm", std::nullopt, Range::NonNegative());
  d.max_rotor_speed = rotor.Number("max_speed_rpm", std::nullopt, Range::Positive());
  d.thrust_coefficient = rotor.Number("thrust_coefficient", std::nullopt, Range::Positive());
  d.torque_coefficient = rotor.Number("torque_coefficient", std::nullopt, Range::Positive());
  d.motor_time_constant = rotor.Number("time_constant", std::nullopt, Range::Positive());

  d.linear_drag = map.Vector3("drag", d.linear_drag);

  const YamlMap collision = map.Map("collision");
  const std::string shape = collision.String("shape", std::nullopt, {"sphere", "box"});
  if (shape == "sphere") {
    collision.RejectUnknownKeys({"shape", "radius"});
    d.collision_shape = CollisionShapeKind::kSphere;
    d.collision_radius = collision.Number("radius", std::nullopt, Range::Positive());
  } else {
    collision.RejectUnknownKeys({"shape", "half_extents"});
    d.collision_shape = CollisionShapeKind::kBox;
    d.collision_half_extents = collision.Vector3("half_extents");
  }
  d.max_speed = map.Number("max_speed", d.max_speed, Range::Positive());

  const YamlMap gains = map.Map("controller", /*optional=*/true);
  gains.RejectUnknownKeys(
      {"position_gain", "velocity_gain", "attitude_gain", "angular_rate_gain"});
  d.gains.position = gains.Vector3("position_gain", d.gains.position);
  d.gains.velocity = gains.Vector3("velocity_gain", d.gains.velocity);
  d.gains.attitude = gains.Vector3("attitude_gain", d.gains.attitude);
  d.gains.angular_rate = gains.Vector3("angular_rate_gain", d.gains.angular_rate);

  d.Validate(file, map.path().empty() ? "" : map.path() + ".");
  return d;
}

DroneDescription LoadDroneDescription(const std::string& path) {
  return DroneDescription::FromYaml(YamlMap::LoadFile(path));
}

std::array<RotorGeometry, 4> RotorLayout(const DroneDescription& drone) {
  std::array<RotorGeometry, 4> rotors{};
  const double offset = drone.configuration == RotorConfiguration::kX ? 0.25 * std::numbers::pi : 0.0;
  for (int i = 0; i < 4; ++i) {
    const double angle = offset + 0.5 * std::numbers::pi * i;
    rotors[static_cast<std::size_t>(i)].position_B =
        drone.arm_length * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    rotors[static_cast<std::size_t>(i)].yaw_torque_sign = (i % 2 == 0) ? -1.0 : 1.0;
  }
  return rotors;
}

}  // namespace quadtune::physics
