#include "quadtune/common/error.hpp"

#include <gtest/gtest.h>

namespace quadtune {
namespace {

TEST(ConfigError, MessageNamesFileAndKey) {
  const ConfigError e("drone.yaml", "rotor.max_speed", "must be positive");
  EXPECT_STREQ(e.what(), "drone.yaml: rotor.max_speed: must be positive");
  EXPECT_EQ(e.file(), "drone.yaml");
  EXPECT_EQ(e.key(), "rotor.max_speed");
}

TEST(ConfigError, OmitsEmptyParts) {
  EXPECT_STREQ(ConfigError("", "", "bad").what(), "bad");
  EXPECT_STREQ(ConfigError("", "k", "bad").what(), "k: bad");
}

TEST(Demand, ThrowsInvariantErrorWithCondition) {
  try {
    QT_DEMAND(1 + 1 == 3, "arithmetic");
    FAIL() << "QT_DEMAND did not throw";
  } catch (const InvariantError& e) {
    EXPECT_NE(std::string(e.what()).find("1 + 1 == 3"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("arithmetic"), std::string::npos);
  }
  EXPECT_NO_THROW(QT_DEMAND(true, ""));
}

}  // namespace
}  // namespace quadtune
