#include "quadtune/common/yaml.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace quadtune {
namespace {

using ::testing::HasSubstr;

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "<no error>";
}

TEST(YamlMap, ReadsTypedValuesWithDefaults) {
  const auto m = YamlMap::FromString("a: 1.5\nb: 3\nc: true\nd: hello\nv: [1, 2, 3]\n", "t.yaml");
  EXPECT_DOUBLE_EQ(m.Number("a"), 1.5);
  EXPECT_EQ(m.Integer("b"), 3);
  EXPECT_TRUE(m.Bool("c"));
  EXPECT_EQ(m.String("d"), "hello");
  EXPECT_EQ(m.Vector3("v"), Eigen::Vector3d(1, 2, 3));
  EXPECT_DOUBLE_EQ(m.Number("missing", 7.0), 7.0);
}

TEST(YamlMap, OutOfRangeNamesFileKeyAndRange) {
  const auto m = YamlMap::FromString("rotor:\n  max_speed: -3\n", "drone.yaml");
  const std::string msg = ErrorOf([&] { (void)m.Map("rotor").Number("max_speed", {}, Range::Positive()); });
  EXPECT_THAT(msg, HasSubstr("drone.yaml"));
  EXPECT_THAT(msg, HasSubstr("rotor.max_speed"));
  EXPECT_THAT(msg, HasSubstr("(0, inf)"));
}

TEST(YamlMap, MissingRequiredKeyIsAnError) {
  const auto m = YamlMap::FromString("a: 1\n", "f.yaml");
  EXPECT_THAT(ErrorOf([&] { (void)m.Number("mass"); }), HasSubstr("f.yaml: mass: missing"));
}

TEST(YamlMap, NonNumberIsAnError) {
  const auto m = YamlMap::FromString("mass: heavy\n", "f.yaml");
  EXPECT_THAT(ErrorOf([&] { (void)m.Number("mass"); }), HasSubstr("'heavy' is not a number"));
}

TEST(YamlMap, UnknownKeyListsAllowedKeys) {
  const auto m = YamlMap::FromString("mass: 1\nmasss: 2\n", "f.yaml");
  const std::string msg = ErrorOf([&] { m.RejectUnknownKeys({"mass", "arm"}); });
  EXPECT_THAT(msg, HasSubstr("masss: unknown key"));
  EXPECT_THAT(msg, HasSubstr("mass, arm"));
}

TEST(YamlMap, StringMustBeAllowed) {
  const auto m = YamlMap::FromString("method: magic\n", "e.yaml");
  EXPECT_THAT(ErrorOf([&] { (void)m.String("method", {}, {"pso", "bo"}); }),
              HasSubstr("expected one of: pso, bo"));
}

TEST(YamlMap, MalformedTextNamesOriginAndLine) {
  EXPECT_THAT(ErrorOf([] { (void)YamlMap::FromString("a: [1, 2\nb: 3\n", "bad.yaml"); }),
              HasSubstr("bad.yaml: malformed YAML at line"));
}

TEST(YamlMap, MissingFileIsAnError) {
  EXPECT_THAT(ErrorOf([] { (void)YamlMap::LoadFile("/nonexistent/x.yaml"); }),
              HasSubstr("/nonexistent/x.yaml: cannot open"));
}

TEST(YamlMap, SequenceOfMapsCarriesIndexInKeyPath) {
  const auto m = YamlMap::FromString("zones:\n  - spacing: 1\n  - spacing: -1\n", "l.yaml");
  const auto zones = m.Maps("zones");
  ASSERT_EQ(zones.size(), 2u);
  EXPECT_THAT(ErrorOf([&] { (void)zones[1].Number("spacing", {}, Range::Positive()); }),
              HasSubstr("zones[1].spacing"));
}

TEST(YamlMap, IntegerRejectsFraction) {
  const auto m = YamlMap::FromString("n: 2.5\n", "f.yaml");
  EXPECT_THAT(ErrorOf([&] { (void)m.Integer("n"); }), HasSubstr("not an integer"));
}

TEST(ApplyAssignments, SetsNestedKeysListsAndNewKeys) {
  const std::string text =
      "budget: {flights: 100, batch: 2}\nstages:\n  - {name: a}\n  - {name: b, x: 1}\n";
  const auto m = YamlMap::FromString(
      ApplyAssignments(text,
                       {"budget.flights=3", "stages.1.x=7", "stages.0.extra.deep=true",
                        "list=[1, 2.5]", "seed=11"},
                       "e.yaml"),
      "e.yaml");
  EXPECT_EQ(m.Map("budget").Integer("flights"), 3);
  EXPECT_EQ(m.Map("budget").Integer("batch"), 2);  // untouched
  EXPECT_EQ(m.Maps("stages")[1].Integer("x"), 7);
  EXPECT_TRUE(m.Maps("stages")[0].Map("extra").Bool("deep"));
  EXPECT_EQ(m.Numbers("list"), (std::vector<double>{1.0, 2.5}));
  EXPECT_EQ(m.Integer("seed"), 11);
  EXPECT_EQ(ApplyAssignments(text, {}, "e.yaml"), text);
}

TEST(ApplyAssignments, EachMalformedAssignmentNamesFileAndKey) {
  const std::string text = "name: x\nstages: [{a: 1}]\n";
  EXPECT_THAT(ErrorOf([&] { (void)ApplyAssignments(text, {"budget.flights"}, "e.yaml"); }),
              HasSubstr("e.yaml: --set: 'budget.flights' is not KEY=VALUE"));
  EXPECT_THAT(ErrorOf([&] { (void)ApplyAssignments(text, {"=3"}, "e.yaml"); }),
              HasSubstr("is not KEY=VALUE"));
  EXPECT_THAT(ErrorOf([&] { (void)ApplyAssignments(text, {"name.sub=3"}, "e.yaml"); }),
              HasSubstr("e.yaml: --set name.sub: 'name.sub': 'name' is not a map"));
  EXPECT_THAT(ErrorOf([&] { (void)ApplyAssignments(text, {"stages.4.a=3"}, "e.yaml"); }),
              HasSubstr("'4' must be an index below 1 of a list"));
  EXPECT_THAT(ErrorOf([&] { (void)ApplyAssignments(text, {"a..b=3"}, "e.yaml"); }),
              HasSubstr("has an empty part"));
  EXPECT_THAT(ErrorOf([&] { (void)ApplyAssignments(text, {"x=[1, 2"}, "e.yaml"); }),
              HasSubstr("the value is not YAML"));
}

}  // namespace
}  // namespace quadtune
