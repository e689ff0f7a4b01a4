#include "quadtune/common/yaml.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "quadtune/common/text_file.hpp"

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

// ---- the text-file checks (quadtune/common/text_file.hpp) YamlMap makes ----

TEST(TextFile, DuplicateKeysAreRefusedAtAnyDepth) {
  EXPECT_THAT(ErrorOf([] { (void)YamlMap::FromString("seed: 7\nseed: 8\n", "e.yaml"); }),
              HasSubstr("e.yaml: seed: key given twice"));
  EXPECT_THAT(ErrorOf([] {
                (void)YamlMap::FromString("a:\n  - {x: 1}\n  - {x: 1, y: 2, y: 3}\n", "e.yaml");
              }),
              HasSubstr("e.yaml: a.1.y: key given twice"));
  EXPECT_EQ(ErrorOf([] { (void)YamlMap::FromString("a: {x: 1}\nb: {x: 1}\n", "e.yaml"); }),
            "<no error>");
}

TEST(TextFile, IntegersAreDecimal) {
  const auto m = YamlMap::FromString("a: 010\nb: +7\nc: 0x10\nd: 1e3\ne: 3.0\nf: -12\n", "i.yaml");
  EXPECT_EQ(m.Integer("a"), 10);
  EXPECT_EQ(m.Integer("b"), 7);
  EXPECT_EQ(m.Integer("f"), -12);
  EXPECT_THAT(ErrorOf([&] { (void)m.Integer("c"); }), HasSubstr("i.yaml: c: '0x10' is not"));
  EXPECT_THAT(ErrorOf([&] { (void)m.Integer("d"); }), HasSubstr("'1e3' is not an integer (decimal"));
  EXPECT_THAT(ErrorOf([&] { (void)m.Integer("e"); }), HasSubstr("'3.0' is not an integer (decimal"));
  EXPECT_THAT(ErrorOf([] {
                (void)YamlMap::FromString("s: 99999999999999999999\n", "i.yaml").Integer("s");
              }),
              HasSubstr("i.yaml: s: '99999999999999999999' is not an integer in"));
}

TEST(TextFile, Utf8IsCheckedWithTheLine) {
  EXPECT_TRUE(IsValidUtf8("plain, é, 漢字, 🚁"));
  EXPECT_FALSE(IsValidUtf8("\xff"));
  EXPECT_FALSE(IsValidUtf8("\xc3"));          // cut short
  EXPECT_FALSE(IsValidUtf8("\xc0\xaf"));      // overlong '/'
  EXPECT_FALSE(IsValidUtf8("\xed\xa0\x80"));  // a surrogate
  EXPECT_FALSE(IsValidUtf8("\xf4\x90\x80\x80"));  // past U+10FFFF
  EXPECT_THAT(ErrorOf([] { (void)YamlMap::FromString("a: 1\nname: x\xfe\n", "u.yaml"); }),
              HasSubstr("u.yaml: line 2 is not valid UTF-8"));
}

TEST(TextFile, DirectoriesAndMissingFilesAreNamed) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("qt_text_file_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  EXPECT_THAT(ErrorOf([&] { (void)YamlMap::LoadFile(dir.string()); }),
              HasSubstr(dir.string() + ": is a directory"));
  EXPECT_THAT(ErrorOf([&] { (void)ReadFileText((dir / "none.yaml").string()); }),
              HasSubstr("none.yaml: cannot open the file: no such file"));
  EXPECT_THAT(ErrorOf([] { (void)ReadFileText("/dev/null"); }), HasSubstr("not a regular file"));
  std::ofstream(dir / "ok.yaml") << "a: 1\n";
  EXPECT_EQ(YamlMap::LoadFile((dir / "ok.yaml").string()).Integer("a"), 1);
  std::filesystem::remove_all(dir);
}

/// A flow list of `n` copies of `item`.
std::string FlowList(std::size_t n, const std::string& item) {
  std::string s = "[";
  for (std::size_t i = 0; i < n; ++i) s.append(i ? ", " : "").append(item);
  return s + "]";
}

/// A block mapping of `n` distinct keys.
std::string BlockMap(std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < n; ++i) s.append("k").append(std::to_string(i)).append(": 1\n");
  return s;
}

TEST(TextFile, AliasesAreRefusedAndNeverExpanded) {
  EXPECT_THAT(ErrorOf([] { (void)YamlMap::FromString("a: &x 1\nb: *x\n", "al.yaml"); }),
              HasSubstr("al.yaml: b: an alias (*name) (line 2); quadtune files do not use YAML "
                        "anchors and aliases"));
  EXPECT_THAT(ErrorOf([] { (void)YamlMap::FromString("a: [&x [1, 2], [*x]]\n", "al.yaml"); }),
              HasSubstr("al.yaml: a.1.0: an alias"));
  EXPECT_THAT(ErrorOf([] { (void)YamlMap::FromString("a: &x {b: 1}\n*x : 2\n", "al.yaml"); }),
              HasSubstr("al.yaml: ?: an alias"));
  EXPECT_EQ(ErrorOf([] { (void)YamlMap::FromString("a: &x 1\n", "al.yaml"); }), "<no error>");
  // The same check on --set values.
  EXPECT_THAT(ErrorOf([] { (void)ApplyAssignments("a: 1\n", {"b=[&x 1, *x]"}, "e.yaml"); }),
              HasSubstr("e.yaml: --set b.1: an alias"));
}

TEST(TextFile, MappingsListsAndNestingHaveStatedLimits) {
  EXPECT_EQ(ErrorOf([] { (void)YamlMap::FromString(BlockMap(kMaxYamlMapKeys), "m.yaml"); }),
            "<no error>");
  EXPECT_THAT(ErrorOf([] { (void)YamlMap::FromString(BlockMap(kMaxYamlMapKeys + 1), "m.yaml"); }),
              HasSubstr("m.yaml: more than 1000 keys in one mapping (line 1001)"));
  const std::string long_list = FlowList(kMaxYamlListEntries + 1, "0");
  EXPECT_THAT(ErrorOf([&] { (void)YamlMap::FromString("a: {}\nb:\n  c: " + long_list, "l.yaml"); }),
              HasSubstr("l.yaml: b.c: more than 100000 entries in one list (line 3)"));
  EXPECT_EQ(ErrorOf([] {
              (void)YamlMap::FromString("c: " + FlowList(kMaxYamlListEntries, "0"), "l.yaml");
            }),
            "<no error>");
  std::string nested = "0";
  for (std::size_t i = 0; i + 1 < kMaxYamlDepth; ++i) nested = "[" + nested + "]";
  EXPECT_EQ(ErrorOf([&] { (void)YamlMap::FromString("a: " + nested, "d.yaml"); }), "<no error>");
  EXPECT_THAT(ErrorOf([&] { (void)YamlMap::FromString("a: [" + nested + "]", "d.yaml"); }),
              HasSubstr("d.yaml: nesting deeper than 64 levels (line 1)"));
}

TEST(TextFile, ValuesAndBytesHaveStatedLimits) {
  // 20 lists of 100 000 zeros: past the values of one text in the last list.
  const std::string list = FlowList(kMaxYamlListEntries, "0");
  std::string text = "a: [" + list;
  for (int i = 1; i * kMaxYamlListEntries < kMaxYamlNodes; ++i) text += ", " + list;
  EXPECT_THAT(ErrorOf([&] { (void)YamlMap::FromString(text + "]", "n.yaml"); }),
              HasSubstr("n.yaml: a.19.99976: more than 2000000 values in the text (line 1)"));
  const auto dir = std::filesystem::temp_directory_path() /
                   ("qt_text_bytes_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto big = dir / "big.yaml";
  std::ofstream(big) << "a: 1\n";
  std::filesystem::resize_file(big, kMaxYamlBytes + 1);  // sparse: nothing is written
  EXPECT_THAT(ErrorOf([&] { (void)YamlMap::LoadFile(big.string()); }),
              HasSubstr("big.yaml: 67108865 bytes; a configuration file holds at most 67108864"));
  std::filesystem::remove_all(dir);
}

TEST(TextFile, DeepNestingIsAConfigError) {
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  EXPECT_THAT(ErrorOf([&] { (void)YamlMap::FromString("a: " + deep, "d.yaml"); }),
              HasSubstr("d.yaml: nesting deeper"));
}

}  // namespace
}  // namespace quadtune
