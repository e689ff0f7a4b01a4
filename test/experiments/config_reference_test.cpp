#include "config_reference.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

namespace quadtune::cli {
namespace {

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The first line where `a` and `b` differ (1-based), with both versions of it.
std::string FirstDifference(const std::string& a, const std::string& b) {
  std::istringstream sa(a);
  std::istringstream sb(b);
  std::string la;
  std::string lb;
  for (int line = 1;; ++line) {
    const bool more_a = static_cast<bool>(std::getline(sa, la));
    const bool more_b = static_cast<bool>(std::getline(sb, lb));
    if (!more_a && !more_b) return "none";
    if (!more_a || !more_b || la != lb) {
      return "line " + std::to_string(line) + ":\n  page:      " + (more_a ? la : "<end>") +
             "\n  generated: " + (more_b ? lb : "<end>");
    }
  }
}

TEST(ConfigReference, DocsPageIsCurrent) {
  const std::string path = std::string(QUADTUNE_SOURCE_DIR) + "/docs/config.md";
  const std::string page = ReadFile(path);
  const std::string generated = ConfigReference();
  EXPECT_TRUE(page == generated)
      << "docs/config.md differs from the field lists; rewrite it with "
         "`build/experiments/quadtune config-reference --out docs/config.md`. First difference, "
      << FirstDifference(page, generated);
}

TEST(ConfigReference, EveryTableRowHasFiveCells) {
  std::istringstream in(ConfigReference());
  int rows = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("| `", 0) != 0) continue;
    ++rows;
    // Key, type, default, allowed, meaning: six bars outside code spans and escapes (\|).
    int bars = 0;
    bool code = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
      if (line[i] == '`') code = !code;
      if (line[i] == '|' && !code && (i == 0 || line[i - 1] != '\\')) ++bars;
    }
    EXPECT_EQ(bars, 6) << line;
  }
  EXPECT_GT(rows, 100);
}

}  // namespace
}  // namespace quadtune::cli
