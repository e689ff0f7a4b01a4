#include "quadtune/common/fields.hpp"

#include <gtest/gtest.h>

#include "../config_error_util.hpp"

namespace quadtune {
namespace {

enum class Shape { kRound, kSquare };
constexpr auto EnumNames(Shape) {
  return std::array{EnumName{Shape::kRound, "round"}, EnumName{Shape::kSquare, "square"}};
}

struct Inner {
  double width = 0.5;
  friend bool operator==(const Inner&, const Inner&) = default;
};

struct Outer {
  int count = 3;
  std::uint64_t seed = 0;
  double gain = 1.5;
  std::optional<double> cap;
  bool loud = false;
  std::string label = "a";
  Shape shape = Shape::kRound;
  Eigen::Vector3d offset = Eigen::Vector3d(0, 0, 1);
  Inner inner;
  friend bool operator==(const Outer&, const Outer&) = default;
};

const Fields<Inner>& InnerFields() {
  static const Fields<Inner> fields =
      Fields<Inner>().Number("width", &Inner::width, Range::Positive(), "width (m)");
  return fields;
}

const Fields<Outer>& OuterFields() {
  static const Fields<Outer> fields =
      Fields<Outer>()
          .Integer("count", &Outer::count, Range::Closed(1, 10), "how many")
          .Required()
          .Integer("seed", &Outer::seed, Range::NonNegative(), "seed")
          .Number("gain", &Outer::gain, Range::Closed(0, 2), "gain")
          .OptionalNumber("cap", &Outer::cap, Range::Positive(), "cap")
          .Flag("loud", &Outer::loud, "loud")
          .Text("label", &Outer::label, {"a", "b"}, "label")
          .Choice("shape", &Outer::shape, "shape")
          .Vector3("offset", &Outer::offset, "offset")
          .Nested("inner", &Outer::inner, InnerFields(), "see Inner");
  return fields;
}

TEST(Fields, ReadsEveryKindAndKeepsDefaultsOfAbsentKeys) {
  const Outer o = OuterFields().Read(YamlMap::FromString(
      "count: 4\ngain: 0.5\ncap: 9\nloud: true\nlabel: b\nshape: square\noffset: [1, 2, 3]\n"
      "inner: {width: 2}\n",
      "f.yaml"));
  EXPECT_EQ(o.count, 4);
  EXPECT_EQ(o.seed, 0U);
  EXPECT_DOUBLE_EQ(o.gain, 0.5);
  ASSERT_TRUE(o.cap.has_value());
  EXPECT_DOUBLE_EQ(*o.cap, 9.0);
  EXPECT_TRUE(o.loud);
  EXPECT_EQ(o.label, "b");
  EXPECT_EQ(o.shape, Shape::kSquare);
  EXPECT_EQ(o.offset, Eigen::Vector3d(1, 2, 3));
  EXPECT_DOUBLE_EQ(o.inner.width, 2.0);

  const Outer d = OuterFields().Read(YamlMap::FromString("count: 1\n", "f.yaml"));
  EXPECT_DOUBLE_EQ(d.gain, 1.5);
  EXPECT_FALSE(d.cap.has_value());
  EXPECT_EQ(d.shape, Shape::kRound);
  EXPECT_DOUBLE_EQ(d.inner.width, 0.5);
}

TEST(Fields, RefusesUnknownMissingAndOutOfRangeKeysNamingFileAndKey) {
  using test::ThrowsConfigError;
  const auto read = [](const std::string& text) {
    return [text] { (void)OuterFields().Read(YamlMap::FromString(text, "f.yaml")); };
  };
  EXPECT_TRUE(ThrowsConfigError(read("count: 1\ncolour: red\n"), "colour",
                                {"f.yaml", "unknown key", "count, seed, gain"}));
  EXPECT_TRUE(ThrowsConfigError(read("gain: 1\n"), "count", {"missing", "integer"}));
  EXPECT_TRUE(ThrowsConfigError(read("count: 11\n"), "count", {"got 11", "[1, 10]"}));
  EXPECT_TRUE(ThrowsConfigError(read("count: 1\nseed: -5\n"), "seed", {"got -5"}));
  EXPECT_TRUE(ThrowsConfigError(read("count: 1\nshape: oval\n"), "shape",
                                {"'oval' is not allowed", "round, square"}));
  EXPECT_TRUE(ThrowsConfigError(read("count: 1\nlabel: c\n"), "label", {"a, b"}));
  EXPECT_TRUE(ThrowsConfigError(read("count: 1\ninner: {width: 0}\n"), "inner.width",
                                {"f.yaml", "(0, inf)"}));
  EXPECT_TRUE(ThrowsConfigError(read("count: 1\ninner: {depth: 1}\n"), "inner.depth",
                                {"unknown key", "width"}));
}

TEST(Fields, FirstBadValueInListOrderIsReported) {
  EXPECT_TRUE(test::ThrowsConfigError(
      [] { (void)OuterFields().Read(YamlMap::FromString("gain: 9\ncount: 0\n", "f.yaml")); },
      "count", {"got 0"}));
}

TEST(Fields, WriteThenReadGivesTheSameValue) {
  Outer o;
  o.count = 7;
  o.seed = 123456789012345ULL;
  o.gain = 0.1 + 0.2;
  o.cap = 1.0 / 3.0;
  o.loud = true;
  o.label = "b";
  o.shape = Shape::kSquare;
  o.offset = Eigen::Vector3d(-1.25, 1e-9, 3);
  o.inner.width = 2.0 / 7.0;
  YAML::Emitter out;
  SetExactDoubles(out);
  OuterFields().Write(out, o);
  EXPECT_EQ(OuterFields().Read(YamlMap::FromString(out.c_str(), "w.yaml")), o);
}

TEST(Fields, CheckAppliesTheReadRangesToValuesBuiltInCode) {
  Outer o;
  EXPECT_NO_THROW(OuterFields().Check(o));
  o.inner.width = -1;
  EXPECT_TRUE(test::ThrowsConfigError([&] { OuterFields().Check(o, "code", "x."); },
                                      "x.inner.width", {"got -1"}));
  o = {};
  o.count = 0;
  EXPECT_TRUE(test::ThrowsConfigError([&] { OuterFields().Check(o); }, "count",
                                      {"an integer in [1, 10]"}));
}

TEST(Fields, DocsListEveryKeyWithDefaultRangeAndMeaning) {
  const std::vector<FieldDoc> rows = OuterFields().Docs();
  ASSERT_EQ(rows.size(), 9U);
  EXPECT_EQ(rows[0].key, "count");
  EXPECT_EQ(rows[0].fallback, "required");
  EXPECT_EQ(rows[0].allowed, "[1, 10]");
  EXPECT_EQ(rows[2].fallback, "1.5");
  EXPECT_EQ(rows[3].fallback, "absent");
  EXPECT_EQ(rows[6].allowed, "`round`, `square`");
  EXPECT_EQ(rows[6].fallback, "`round`");
  EXPECT_EQ(rows[7].fallback, "[0, 0, 1]");
  const std::string table = MarkdownTable(rows);
  EXPECT_NE(table.find("| `gain` | number | 1.5 | [0, 2] | gain |"), std::string::npos);
}

TEST(EnumNames, RoundTripAndUnknownNames) {
  EXPECT_STREQ(ToString(Shape::kSquare), "square");
  EXPECT_EQ(FromString<Shape>("round"), Shape::kRound);
  EXPECT_FALSE(FromString<Shape>("oval").has_value());
  EXPECT_EQ(EnumNameList<Shape>(), (std::vector<std::string>{"round", "square"}));
}

}  // namespace
}  // namespace quadtune
