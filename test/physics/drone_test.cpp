#include "quadtune/physics/drone.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <functional>
#include <string>
#include <string_view>

#include "../config_error_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
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

// One test per documented bad input: the error names the key of the rule that rejects it (so a
// deleted rule cannot hide behind a later one) and says what is allowed.
using test::ThrowsConfigError;

// The edit is rejected with a ConfigError naming `key` whose message holds `words`.
::testing::AssertionResult Rejects(const std::function<void(YAML::Node&)>& edit,
                                   std::string_view key,
                                   std::initializer_list<std::string_view> words) {
  return ThrowsConfigError([&] { LoadEdited(edit); }, key, words);
}

TEST(DroneDescription, RejectsMissingFile) {
  const std::string path = kDrones + "no_such_drone.yaml";
  EXPECT_TRUE(ThrowsConfigError([&] { (void)LoadDroneDescription(path); }, "",
                                {"no_such_drone.yaml", "cannot open"}));
}
TEST(DroneDescription, RejectsMalformedYaml) {
  EXPECT_TRUE(ThrowsConfigError(
      [] { DroneDescription::FromYaml(YamlMap::FromString("mass: [1, 2", "bad.yaml")); }, "",
      {"bad.yaml", "malformed YAML at line"}));
}
TEST(DroneDescription, RejectsUnknownTopLevelKey) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["masss"] = 1.0; }, "masss",
                      {"unknown key", "mass", "arm_length"}));
}
TEST(DroneDescription, RejectsUnknownRotorKey) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["rotor"]["kf"] = 1.0; }, "rotor.kf",
                      {"unknown key", "thrust_coefficient"}));
}
TEST(DroneDescription, RejectsUnknownControllerKey) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["controller"]["ki"] = 1.0; }, "controller.ki",
                      {"unknown key", "position_gain"}));
}
TEST(DroneDescription, RejectsMissingMass) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n.remove("mass"); }, "mass", {"missing"}));
}
TEST(DroneDescription, RejectsNonPositiveMass) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["mass"] = 0.0; }, "mass", {"got 0", "(0, "}));
}
TEST(DroneDescription, RejectsNonNumericMass) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["mass"] = "heavy"; }, "mass", {"heavy"}));
}
TEST(DroneDescription, RejectsInertiaOfWrongLength) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["inertia"].push_back(1.0); }, "inertia", {"3"}));
}
TEST(DroneDescription, RejectsNonPositiveInertia) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["inertia"][0] = -1e-3; }, "inertia[0]", {"(0, "}));
}
TEST(DroneDescription, RejectsInertiaViolatingTriangleInequality) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["inertia"][2] = 1.0; }, "inertia",
                      {"triangle inequality", "I[2]"}));
}
TEST(DroneDescription, RejectsNonPositiveArm) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["arm_length"] = 0.0; }, "arm_length", {"(0, "}));
}
TEST(DroneDescription, RejectsUnknownConfiguration) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["configuration"] = "hexa"; }, "configuration",
                      {"hexa", "x", "plus"}));
}
TEST(DroneDescription, RejectsNegativeMinRotorSpeed) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["rotor"]["min_speed_rpm"] = -1.0; },
                      "rotor.min_speed_rpm", {"got -1", "[0, "}));
}
// min >= max also makes the descent check fail (thrust at min_speed_rpm >= thrust at max >
// weight), so only the key and the message tell the order rule from the descent rule.
TEST(DroneDescription, RejectsMinNotBelowMaxRotorSpeed) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["rotor"]["min_speed_rpm"] = 35000.0; },
                      "rotor.max_speed_rpm", {"got 35000", "(35000, "}));
}
TEST(DroneDescription, RejectsThrustToWeightAtMostOne) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["rotor"]["thrust_coefficient"] = 1e-9; },
                      "rotor.thrust_coefficient", {"thrust-to-weight", "must exceed 1"}));
}
TEST(DroneDescription, RejectsMinSpeedThatCannotDescend) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["rotor"]["min_speed_rpm"] = 25000.0; },
                      "rotor.min_speed_rpm", {"descend"}));
}
TEST(DroneDescription, RejectsNonPositiveThrustCoefficient) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["rotor"]["thrust_coefficient"] = 0.0; },
                      "rotor.thrust_coefficient", {"got 0", "(0, "}));
}
TEST(DroneDescription, RejectsNonPositiveTorqueCoefficient) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["rotor"]["torque_coefficient"] = -1e-10; },
                      "rotor.torque_coefficient", {"(0, "}));
}
TEST(DroneDescription, RejectsNonPositiveMotorTimeConstant) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["rotor"]["time_constant"] = 0.0; },
                      "rotor.time_constant", {"got 0", "(0, "}));
}
TEST(DroneDescription, RejectsNegativeDrag) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["drag"][2] = -0.1; }, "drag[2]", {"got -0.1", "[0, "}));
}
TEST(DroneDescription, RejectsUnknownCollisionShape) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["collision"]["shape"] = "cone"; }, "collision.shape",
                      {"cone", "sphere", "box"}));
}
TEST(DroneDescription, RejectsNonPositiveCollisionRadius) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["collision"]["radius"] = 0.0; }, "collision.radius",
                      {"got 0", "(0, "}));
}
TEST(DroneDescription, RejectsNonPositiveBoxHalfExtent) {
  EXPECT_TRUE(Rejects(
      [](YAML::Node& n) {
        n["collision"] = YAML::Load("{shape: box, half_extents: [0.2, 0.0, 0.05]}");
      },
      "collision.half_extents[1]", {"got 0", "(0, "}));
}
// A complete box (half_extents given) with a stray radius: only the unknown-key rule rejects it.
TEST(DroneDescription, RejectsRadiusKeyOnBox) {
  EXPECT_TRUE(Rejects(
      [](YAML::Node& n) {
        n["collision"] = YAML::Load("{shape: box, half_extents: [0.2, 0.2, 0.05], radius: 0.2}");
      },
      "collision.radius", {"unknown key", "half_extents"}));
}
TEST(DroneDescription, RejectsNonPositiveMaxSpeed) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["max_speed"] = 0.0; }, "max_speed", {"(0, "}));
}
TEST(DroneDescription, RejectsNonPositiveGain) {
  EXPECT_TRUE(Rejects([](YAML::Node& n) { n["controller"]["attitude_gain"][0] = 0.0; },
                      "controller.attitude_gain[0]", {"(0, "}));
}

TEST(DroneDescription, AcceptsBoxCollisionShape) {
  const DroneDescription d = LoadEdited([](YAML::Node& n) {
    n["collision"] = YAML::Load("{shape: box, half_extents: [0.2, 0.2, 0.05]}");
  });
  EXPECT_EQ(d.collision_shape, CollisionShapeKind::kBox);
  EXPECT_NEAR(d.InscribedRadius(), 0.05, 1e-12);
  EXPECT_NEAR(d.BoundingRadius(), std::sqrt(0.04 + 0.04 + 0.0025), 1e-12);
}

// DroneFields().Write, read back by FromYaml, gives the same description.
DroneDescription RoundTrip(const DroneDescription& d) {
  YAML::Emitter out;
  SetExactDoubles(out);
  DroneFields().Write(out, d);
  return DroneDescription::FromYaml(YamlMap::FromString(out.c_str(), "written.yaml"));
}

TEST(DroneDescription, WrittenFieldsReadBackEqual) {
  DroneDescription d = LoadDroneDescription(kDrones + "crazyflie.yaml");
  d.mass *= 1.0 + 1.0 / 3.0;  // not representable in few digits
  d.configuration = RotorConfiguration::kPlus;
  d.gains.attitude.x() = 123.456789012345;
  EXPECT_EQ(RoundTrip(d), d);
  DroneDescription box = LoadEdited([](YAML::Node& n) {
    n["collision"] = YAML::Load("{shape: box, half_extents: [0.2, 0.15, 0.05]}");
  });
  EXPECT_EQ(RoundTrip(box), box);
}

TEST(DroneDescription, EnumNamesAreTheFileSpellings) {
  EXPECT_STREQ(ToString(RotorConfiguration::kX), "x");
  EXPECT_EQ(FromString<RotorConfiguration>("plus"), RotorConfiguration::kPlus);
  EXPECT_STREQ(ToString(CollisionShapeKind::kBox), "box");
  EXPECT_EQ(FromString<CollisionShapeKind>("sphere"), CollisionShapeKind::kSphere);
  EXPECT_FALSE(FromString<CollisionShapeKind>("cone").has_value());
}

}  // namespace
}  // namespace quadtune::physics
