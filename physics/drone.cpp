#include "quadtune/physics/drone.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
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

// The first key of either collision map.
Fields<DroneDescription> CollisionShapeField() {
  Fields<DroneDescription> fields;
  fields
      .Choice("shape", &DroneDescription::collision_shape,
              "collision body: `sphere` (with `radius`) or `box` (with `half_extents`)")
      .Required();
  return fields;
}

// The collision map's keys for `shape`.
const Fields<DroneDescription>& CollisionFieldsOf(CollisionShapeKind shape) {
  return shape == CollisionShapeKind::kSphere ? SphereCollisionFields() : BoxCollisionFields();
}

}  // namespace

const Fields<DroneDescription>& RotorFields() {
  static const Fields<DroneDescription> fields =
      Fields<DroneDescription>()
          .Number("min_speed_rpm", &DroneDescription::min_rotor_speed, Range::NonNegative(),
                  "least rotor speed (rpm); below `max_speed_rpm` and low enough that the drone "
                  "can descend (thrust-to-weight < 1)")
          .Required()
          .Number("max_speed_rpm", &DroneDescription::max_rotor_speed, Range::Positive(),
                  "top rotor speed (rpm); a drone that cannot lift itself there (thrust-to-weight "
                  "≤ 1) is refused")
          .Required()
          .Number("thrust_coefficient", &DroneDescription::thrust_coefficient, Range::Positive(),
                  "kf: thrust = kf ω² (N/rpm²)")
          .Required()
          .Number("torque_coefficient", &DroneDescription::torque_coefficient, Range::Positive(),
                  "km: drag torque = km ω² (N·m/rpm²)")
          .Required()
          .Number("time_constant", &DroneDescription::motor_time_constant, Range::Positive(),
                  "first-order motor lag (s)")
          .Required();
  return fields;
}

const Fields<DroneDescription>& SphereCollisionFields() {
  static const Fields<DroneDescription> fields =
      CollisionShapeField()
          .Number("radius", &DroneDescription::collision_radius, Range::Positive(),
                  "sphere radius (m), centred on the centre of mass")
          .Required();
  return fields;
}

const Fields<DroneDescription>& BoxCollisionFields() {
  static const Fields<DroneDescription> fields =
      CollisionShapeField()
          .Vector3("half_extents", &DroneDescription::collision_half_extents,
                   "box half sizes along the body axes (m), each > 0")
          .Required();
  return fields;
}

const Fields<ControllerGains>& ControllerFields() {
  static const Fields<ControllerGains> fields =
      Fields<ControllerGains>()
          .Vector3("position_gain", &ControllerGains::position,
                   "kp, normalised by mass (1/s²), world x, y, z; each > 0")
          .Vector3("velocity_gain", &ControllerGains::velocity,
                   "kv, normalised by mass (1/s), world x, y, z; each > 0")
          .Vector3("attitude_gain", &ControllerGains::attitude,
                   "kR, normalised by inertia (1/s²), body x, y, z; each > 0")
          .Vector3("angular_rate_gain", &ControllerGains::angular_rate,
                   "kω, normalised by inertia (1/s), body x, y, z; each > 0");
  return fields;
}

const Fields<DroneDescription>& DroneFields() {
  static const Fields<DroneDescription> fields =
      Fields<DroneDescription>()
          .Text("name", &DroneDescription::name, {}, "name of the drone")
          .Number("mass", &DroneDescription::mass, Range::Positive(), "mass (kg)")
          .Required()
          .Vector3("inertia", &DroneDescription::inertia,
                   "principal moments of inertia, body axes (kg·m²); each > 0 and at most the "
                   "sum of the other two")
          .Required()
          .Number("arm_length", &DroneDescription::arm_length, Range::Positive(),
                  "centre of mass to rotor axis (m)")
          .Required()
          .Choice("configuration", &DroneDescription::configuration,
                  "rotors at ±45°/±135° (`x`) or on the body axes (`plus`)")
          .Required()
          .Custom(
              {"rotor", "map", "", "", "rotor speeds and coefficients (see Drone: rotor)"},
              [](const YamlMap& m, DroneDescription& d) { RotorFields().Read(m.Map("rotor"), d); },
              [](YAML::Emitter& out, const DroneDescription& d) {
                out << YAML::Key << "rotor" << YAML::Value;
                RotorFields().Write(out, d);
              })
          .Required()
          .Vector3("drag", &DroneDescription::linear_drag,
                   "linear drag per body axis (N·s/m), each ≥ 0")
          .Custom(
              {"collision", "map", "", "",
               "collision body: `{shape: sphere, radius}` or `{shape: box, half_extents}` "
               "(see Drone: collision)"},
              [](const YamlMap& m, DroneDescription& d) {
                const YamlMap collision = m.Map("collision");
                CollisionFieldsOf(ReadEnum<CollisionShapeKind>(collision, "shape", std::nullopt))
                    .Read(collision, d);
              },
              [](YAML::Emitter& out, const DroneDescription& d) {
                out << YAML::Key << "collision" << YAML::Value;
                CollisionFieldsOf(d.collision_shape).Write(out, d);
              })
          .Required()
          .Number("max_speed", &DroneDescription::max_speed, Range::Positive(),
                  "top speed the world must handle (m/s)")
          .Nested("controller", &DroneDescription::gains, ControllerFields(),
                  "SE(3) tracking-controller gains (see Drone: controller)");
  return fields;
}

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
  DroneFields().Check(*this, origin, key_prefix);  // mass, arm_length, max_speed
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
  RotorFields().Check(*this, origin, K("rotor."));
  CheckInRange(max_rotor_speed,
               {min_rotor_speed, std::numeric_limits<double>::infinity(), true, false}, origin,
               K("rotor.max_speed_rpm"));
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
  CollisionFieldsOf(collision_shape).Check(*this, origin, K("collision."));
  if (collision_shape == CollisionShapeKind::kBox) {
    CheckPositiveVector(collision_half_extents, origin, K("collision.half_extents"));
  }
  CheckPositiveVector(gains.position, origin, K("controller.position_gain"));
  CheckPositiveVector(gains.velocity, origin, K("controller.velocity_gain"));
  CheckPositiveVector(gains.attitude, origin, K("controller.attitude_gain"));
  CheckPositiveVector(gains.angular_rate, origin, K("controller.angular_rate_gain"));
}

DroneDescription DroneDescription::FromYaml(const YamlMap& map) {
  const DroneDescription d = DroneFields().Read(map);
  d.Validate(map.file(), map.path().empty() ? "" : map.path() + ".");
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
