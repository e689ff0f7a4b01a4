// Hostile inputs through the `quadtune` program under bounds this harness enforces: each must be
// refused with exit 2 and one line on stderr naming the file (or option), the key, the value and
// the limit, within kDeadlineS seconds (the child is killed past it) and with a peak resident
// memory under kPeakRssMib, in an address space of kAddressSpaceMib. Without the bound in the
// code each case runs on (alias expansion, a quadratic check, a runaway allocation) and fails
// here.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "../bounded_run.hpp"
#include "../cli_util.hpp"

namespace quadtune::test {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr double kDeadlineS = 2.0;
constexpr long kPeakRssMib = 200;
constexpr long kAddressSpaceMib = 4096;

/// The "billion laughs" shape as one flow list: nine levels, each nine aliases of the one
/// before (9^9 strings once expanded).
std::string AliasBomb() {
  std::string s = "[&l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]";
  for (int level = 1; level <= 8; ++level) {
    s += ", &l" + std::to_string(level) + " [";
    for (int i = 0; i < 9; ++i) s += (i ? ", *l" : "*l") + std::to_string(level - 1);
    s += "]";
  }
  return s + "]";
}

/// A fresh folder holding the toy experiment as toy.yaml.
fs::path CaseDir(const std::string& name) {
  const fs::path dir = FreshTempDir("qt_bounded_" + name + "_" + std::to_string(::getpid()));
  fs::copy_file(ToyExperimentFile(), dir / "toy.yaml");
  return dir;
}

void Write(const fs::path& file, const std::string& text) { std::ofstream(file) << text; }

/// Runs `args` under the bounds; the refusal must be prompt, small, exit 2 and one stderr line
/// holding every `expect`.
void ExpectBoundedRefusal(const std::vector<std::string>& args, const fs::path& dir,
                          const std::vector<std::string>& expect) {
  BoundedChild child(args, dir / "log", kAddressSpaceMib);
  const BoundedResult r = child.Wait(kDeadlineS);
  EXPECT_FALSE(r.killed_at_deadline) << "still running after " << kDeadlineS << " s";
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_LT(r.seconds, kDeadlineS);
  EXPECT_LT(r.peak_rss_mib, kPeakRssMib);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  for (const auto& e : expect) EXPECT_THAT(r.err, HasSubstr(e));
  EXPECT_FALSE(fs::exists(dir / "out" / "results.sqlite"));
}

TEST(BoundedParsing, AliasBombInAnExperimentFileIsRefused) {
  const fs::path dir = CaseDir("alias_file");
  Write(dir / "bomb.yaml", ReadText(dir / "toy.yaml") + "laughs: " + AliasBomb() + "\n");
  ExpectBoundedRefusal({"run", (dir / "bomb.yaml").string(), "--out", (dir / "out").string(),
                        "--no-plot", "--quiet"},
                       dir, {"bomb.yaml: laughs.1.0: an alias (*name)", "anchors and aliases"});
}

TEST(BoundedParsing, AliasBombThroughSetIsRefused) {
  const fs::path dir = CaseDir("alias_set");
  ExpectBoundedRefusal({"run", (dir / "toy.yaml").string(), "--set", "laughs=" + AliasBomb(),
                        "--out", (dir / "out").string(), "--no-plot", "--quiet"},
                       dir, {"toy.yaml: --set laughs.1.0: an alias (*name)"});
}

TEST(BoundedParsing, AliasBombInAStudyOverrideIsRefused) {
  const fs::path dir = CaseDir("alias_study");
  Write(dir / "study.yaml", "name: st\nseed: 4\nexperiment: toy.yaml\noverride: {laughs: " +
                                AliasBomb() +
                                "}\nsweep: {key: planner.toy.gates, values: [2, 4]}\n");
  ExpectBoundedRefusal({"study", (dir / "study.yaml").string(), "--out", (dir / "out").string(),
                        "--no-plot", "--quiet"},
                       dir, {"study.yaml: override.laughs.1.0: an alias (*name)"});
}

TEST(BoundedParsing, AHundredThousandKeyMappingIsRefused) {
  const fs::path dir = CaseDir("keys");
  std::string text = ReadText(dir / "toy.yaml") + "many:\n";
  for (int i = 0; i < 100000; ++i) text += "  k" + std::to_string(i) + ": 1\n";
  Write(dir / "keys.yaml", text);
  ExpectBoundedRefusal({"run", (dir / "keys.yaml").string(), "--out", (dir / "out").string(),
                        "--no-plot", "--quiet"},
                       dir, {"keys.yaml: many: more than 1000 keys in one mapping (line"});
}

}  // namespace
}  // namespace quadtune::test
