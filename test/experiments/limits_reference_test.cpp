// The limits section of docs/hardening.md is what `quadtune limits-reference` writes from the
// constants the checks use and the field lists.
#include "limits_reference.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "quadtune/common/error.hpp"
#include "quadtune/common/text_file.hpp"

namespace quadtune::cli {
namespace {

using ::testing::HasSubstr;

TEST(LimitsReference, HardeningPageIsCurrent) {
  const std::string path = std::string(QUADTUNE_SOURCE_DIR) + "/docs/hardening.md";
  const std::string page = ReadFileText(path);
  EXPECT_TRUE(page == WithLimitsReference(page, path))
      << "the limits section of docs/hardening.md differs from the code; rewrite it with "
         "`build/experiments/quadtune limits-reference --out docs/hardening.md`";
}

TEST(LimitsReference, ListsTheParsingCommandLineAndFieldListLimits) {
  const std::string text = LimitsReference();
  EXPECT_THAT(text, HasSubstr("| keys of one mapping | 1000 |"));
  EXPECT_THAT(text, HasSubstr("| `bench --max-threads` | 256 |"));
  EXPECT_THAT(text, HasSubstr("| `sweep`: N·(d+2)·K flights per layout | 1000000 |"));
  EXPECT_THAT(text, HasSubstr("| `budget.flights` | [1, 100000] |"));
  EXPECT_THAT(text, HasSubstr("| `threads` | [1, 1024] |"));
}

TEST(LimitsReference, RewritesOnlyItsSection) {
  const std::string page = "# T\n\nbefore\n\n" + std::string(kLimitsBegin) + "\nold\n" +
                           kLimitsEnd + "\n\nafter\n";
  EXPECT_EQ(WithLimitsReference(page, "p.md"), "# T\n\nbefore\n\n" + LimitsReference() + "\nafter\n");
  EXPECT_THROW((void)WithLimitsReference("# no markers\n", "p.md"), ConfigError);
}

}  // namespace
}  // namespace quadtune::cli
