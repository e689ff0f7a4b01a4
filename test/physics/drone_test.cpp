#include "quadtune/physics/drone.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <functional>
#include <string>

#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::physics {
namespace {

const std::string kDrones = std::string(QUADTUNE_SOURCE_DIR) + "/assets/drones/";

// Loads research_1kg.yaml, lets `edit` change it and parses the result as "edited.yaml".
DroneDescription LoadEdited(const std::function<void(YAML::Node&)>& edit) {
  YAML::Node root = YAML::LoadFile(kDrones + "research_1kg.yaml");
  edit(root);
  YAML::Emitter out;
  out << root;
  return DroneDescription::FromYaml(YamlMap::FromString(out.c_str(), "edited.yaml"));
}

// The ConfigError thrown for an edit (fails the test when nothing is thrown).
ConfigError ErrorFor(const std::function<void(YAML::Node&)>& edit) {
  try {
    LoadEdited(edit);
  } catch (const ConfigError& e) {
    return e;
  }
  ADD_FAILURE() << "no ConfigError thrown";
  return ConfigError("", "", "");
}

TEST(DroneDescription, ShippedDescriptionsLoadWithRealisticThrust) {
  const DroneDescription research = LoadDroneDescription(kDrones + "research_1kg.yaml");
  EXPECT_EQ(research.name, "research_1kg");
  EXPECT_DOUBLE_EQ(research.mass, 0.98);
  EXPECT_DOUBLE_EQ(research.inertia.z(), 4.96e-3);
  EXPECT_DOUBLE_EQ(research.arm_length, 0.26);
  EXPECT_NEAR(research.motor_time_constant, 1.0 / 30.0, 1e-9);
  EXPECT_DOUBLE_EQ(research.min_rotor_speed, 1200.0);
  EXPECT_DOUBLE_EQ(research.max_rotor_speed, 35000.0);
  EXPECT_GT(research.ThrustToWeight(), 2.5);
  EXPECT_LT(research.ThrustToWeight(), 3.0);

  const DroneDescription agile = LoadDroneDescription(kDrones + "agile_small.yaml");
  EXPECT_GE(agile.mass, 0.4);
  EXPECT_LE(agile.mass, 0.6);
  EXPECT_GT(agile.ThrustToWeight(), 4.0);

  const DroneDescription cf = LoadDroneDescription(kDrones + "crazyflie.yaml");
  EXPECT_DOUBLE_EQ(cf.mass, 0.027);
  EXPECT_DOUBLE_EQ(cf.thrust_coefficient, 3.16e-10);
  EXPECT_NEAR(cf.ThrustToWeight(), 2.25, 0.01);
}

TEST(DroneDescription, HoverSpeedCarriesTheWeight) {
  const DroneDescription d;
  const double w = d.HoverRotorSpeed();
  EXPECT_NEAR(4.0 * d.thrust_coefficient * w * w, d.mass * kGravity, 1e-12);
  EXPECT_GT(w, d.min_rotor_speed);
  EXPECT_LT(w, d.max_rotor_speed);
}

TEST(DroneDescription, DefaultsMatchResearchFile) {
  DroneDescription file = LoadDroneDescription(kDrones + "research_1kg.yaml");
  const DroneDescription defaults;
  EXPECT_EQ(file, defaults);
}

TEST(DroneDescription, RotorLayoutXAndPlus) {
  DroneDescription d;
  auto x = RotorLayout(d);
  const double a = d.arm_length / std::sqrt(2.0);
  EXPECT_NEAR(x[0].position_B.x(), a, 1e-12);
  EXPECT_NEAR(x[0].position_B.y(), a, 1e-12);
  EXPECT_NEAR(x[2].position_B.x(), -a, 1e-12);
  EXPECT_EQ(x[0].yaw_torque_sign, x[2].yaw_torque_sign);
  EXPECT_EQ(x[1].yaw_torque_sign, -x[0].yaw_torque_sign);
  d.configuration = RotorConfiguration::kPlus;
  auto plus = RotorLayout(d);
  EXPECT_NEAR(plus[0].position_B.x(), d.arm_length, 1e-12);
  EXPECT_NEAR(plus[1].position_B.y(), d.arm_length, 1e-12);
}

TEST(DroneDescription, ErrorsNameFileAndKey) {
  const ConfigError e = ErrorFor([](YAML::Node& n) { n["rotor"]["max_speed_rpm"] = 1000; });
  EXPECT_EQ(e.file(), "edited.yaml");
  EXPECT_EQ(e.key(), "rotor.max_speed_rpm");
  EXPECT_NE(std::string(e.what()).find("edited.yaml"), std::string::npos);
  EXPECT_EQ(ErrorFor([](YAML::Node& n) { n["mass"] = -1.0; }).key(), "mass");
  EXPECT_EQ(ErrorFor([](YAML::Node& n) { n["inertia"][1] = 0.0; }).key(), "inertia[1]");
}

// One EXPECT_THROW per documented bad input.
TEST(DroneDescription, RejectsMissingFile) {
  EXPECT_THROW(LoadDroneDescription(kDrones + "no_such_drone.yaml"), ConfigError);
}
TEST(DroneDescription, RejectsMalformedYaml) {
  EXPECT_THROW(DroneDescription::FromYaml(YamlMap::FromString("mass: [1, 2", "bad.yaml")),
               ConfigError);
}
TEST(DroneDescription, RejectsUnknownTopLevelKey) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["masss"] = 1.0; }), ConfigError);
}
TEST(DroneDescription, RejectsUnknownRotorKey) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["rotor"]["kf"] = 1.0; }), ConfigError);
}
TEST(DroneDescription, RejectsUnknownControllerKey) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["controller"]["ki"] = 1.0; }), ConfigError);
}
TEST(DroneDescription, RejectsMissingMass) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n.remove("mass"); }), ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveMass) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["mass"] = 0.0; }), ConfigError);
}
TEST(DroneDescription, RejectsNonNumericMass) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["mass"] = "heavy"; }), ConfigError);
}
TEST(DroneDescription, RejectsInertiaOfWrongLength) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["inertia"].push_back(1.0); }), ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveInertia) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["inertia"][0] = -1e-3; }), ConfigError);
}
TEST(DroneDescription, RejectsInertiaViolatingTriangleInequality) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["inertia"][2] = 1.0; }), ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveArm) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["arm_length"] = 0.0; }), ConfigError);
}
TEST(DroneDescription, RejectsUnknownConfiguration) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["configuration"] = "hexa"; }), ConfigError);
}
TEST(DroneDescription, RejectsNegativeMinRotorSpeed) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["rotor"]["min_speed_rpm"] = -1.0; }), ConfigError);
}
TEST(DroneDescription, RejectsMinNotBelowMaxRotorSpeed) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["rotor"]["min_speed_rpm"] = 35000.0; }),
               ConfigError);
}
TEST(DroneDescription, RejectsThrustToWeightAtMostOne) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["rotor"]["thrust_coefficient"] = 1e-9; }),
               ConfigError);
}
TEST(DroneDescription, RejectsMinSpeedThatCannotDescend) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["rotor"]["min_speed_rpm"] = 25000.0; }),
               ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveThrustCoefficient) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["rotor"]["thrust_coefficient"] = 0.0; }),
               ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveTorqueCoefficient) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["rotor"]["torque_coefficient"] = -1e-10; }),
               ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveMotorTimeConstant) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["rotor"]["time_constant"] = 0.0; }), ConfigError);
}
TEST(DroneDescription, RejectsNegativeDrag) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["drag"][2] = -0.1; }), ConfigError);
}
TEST(DroneDescription, RejectsUnknownCollisionShape) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["collision"]["shape"] = "cone"; }), ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveCollisionRadius) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["collision"]["radius"] = 0.0; }), ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveBoxHalfExtent) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) {
                 n["collision"] = YAML::Load("{shape: box, half_extents: [0.2, 0.0, 0.05]}");
               }),
               ConfigError);
}
TEST(DroneDescription, RejectsRadiusKeyOnBox) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) {
                 n["collision"] = YAML::Load("{shape: box, radius: 0.2}");
               }),
               ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveMaxSpeed) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["max_speed"] = 0.0; }), ConfigError);
}
TEST(DroneDescription, RejectsNonPositiveGain) {
  EXPECT_THROW(LoadEdited([](YAML::Node& n) { n["controller"]["attitude_gain"][0] = 0.0; }),
               ConfigError);
}

TEST(DroneDescription, AcceptsBoxCollisionShape) {
  const DroneDescription d = LoadEdited([](YAML::Node& n) {
    n["collision"] = YAML::Load("{shape: box, half_extents: [0.2, 0.2, 0.05]}");
  });
  EXPECT_EQ(d.collision_shape, CollisionShapeKind::kBox);
  EXPECT_NEAR(d.InscribedRadius(), 0.05, 1e-12);
  EXPECT_NEAR(d.BoundingRadius(), std::sqrt(0.04 + 0.04 + 0.0025), 1e-12);
}

}  // namespace
}  // namespace quadtune::physics
