// Reading configuration text safely (quadtune/common/text_file.hpp) and the checks YamlMap makes
// with it: duplicate keys, decimal integers, UTF-8, directories, deep nesting.
#include "quadtune/common/text_file.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "quadtune/common/yaml.hpp"

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
              HasSubstr("none.yaml: no such file"));
  EXPECT_THAT(ErrorOf([] { (void)ReadFileText("/dev/null"); }), HasSubstr("not a regular file"));
  std::ofstream(dir / "ok.yaml") << "a: 1\n";
  EXPECT_EQ(YamlMap::LoadFile((dir / "ok.yaml").string()).Integer("a"), 1);
  std::filesystem::remove_all(dir);
}

TEST(TextFile, DeepNestingIsAConfigError) {
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  EXPECT_THAT(ErrorOf([&] { (void)YamlMap::FromString("a: " + deep, "d.yaml"); }),
              HasSubstr("d.yaml: nesting deeper"));
}

}  // namespace
}  // namespace quadtune
