#include "quadtune/planning/parameters.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "../config_error_util.hpp"
#include "quadtune/planning/parameter_schema.hpp"

namespace quadtune::planning {
namespace {

using ::testing::HasSubstr;

TEST(PlannerParams, DefaultsAreValid) { EXPECT_NO_THROW(PlannerParams{}.Validate()); }

TEST(PlannerParams, NamedAccessRoundTrips) {
  PlannerParams p;
  for (const auto& name : PlannerParams::TunableNames()) {
    p.Set(name, p.Get(name) * 1.5);
  }
  EXPECT_DOUBLE_EQ(p.Get("v_des"), 3.0);
  EXPECT_EQ(p.n_pol, 8);  // 5 * 1.5 = 7.5 rounds to 8
  EXPECT_EQ(PlannerParams::ShortTermNames().size() + PlannerParams::LongTermNames().size(),
            PlannerParams::TunableNames().size());
}

TEST(PlannerParams, UnknownNameThrows) {
  PlannerParams p;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { p.Set("w_colision", 1.0); }, "w_colision",
                                                  {"allowed: w_col, w_dyn, n_pol, v_des, h_p"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { (void)p.Get("speed"); }, "speed",
                                                  {"allowed: w_col, w_dyn, n_pol, v_des, h_p"}));
}

TEST(PlannerParams, OutOfRangeNamesKey) {
  PlannerParams p;
  p.n_pol = 1;
  try {
    p.Validate("exp.yaml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "n_pol");
    EXPECT_THAT(e.what(), HasSubstr("exp.yaml"));
  }
  p = PlannerParams{};
  p.v_des = 0.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { p.Validate(); }, "v_des",
                                                  {"allowed: a number in (0, 15]"}));
  p = PlannerParams{};
  p.w_col = -1.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { p.Validate(); }, "w_col",
                                                  {"allowed: a number in (0, inf)"}));
}

TEST(PlannerParams, WrittenParametersReadBackEqual) {
  PlannerParams p;
  p.w_col = 0.123456789012345;
  p.n_pol = 9;
  p.v_des = 1.0 / 3.0;
  p.max_attempts = 1;
  YAML::Emitter out;
  SetExactDoubles(out);
  PlannerParamsFields().Write(out, p);
  EXPECT_EQ(PlannerParams::FromYaml(YamlMap::FromString(out.c_str(), "p.yaml")), p) << out.c_str();
}

TEST(PlannerParams, SchemaListsEveryFieldOnceWithItsRoleRangeAndDefault) {
  const auto& schema = PlannerParameterSchema();
  ASSERT_EQ(schema.size(), PlannerParamsFields().Keys().size());
  std::vector<std::string> short_term, long_term;
  for (std::size_t i = 0; i < schema.size(); ++i) {
    const PlannerParameterInfo& row = schema[i];
    EXPECT_EQ(row.name, PlannerParamsFields().Keys()[i]);
    EXPECT_EQ(row.fallback, PlannerParams{}.Get(row.name)) << row.name;
    EXPECT_EQ(row.integer, ParameterIsInteger(row.name));
    EXPECT_TRUE(row.range.Contains(row.fallback)) << row.name;
    EXPECT_FALSE(row.meaning.empty());
    if (row.role == ParameterRole::kShortTerm) short_term.push_back(row.name);
    if (row.role == ParameterRole::kLongTerm) long_term.push_back(row.name);
  }
  EXPECT_EQ(short_term, PlannerParams::ShortTermNames());
  EXPECT_EQ(long_term, PlannerParams::LongTermNames());
  EXPECT_EQ(short_term, (std::vector<std::string>{"w_col", "w_dyn", "n_pol"}));
  EXPECT_EQ(long_term, (std::vector<std::string>{"v_des", "h_pl", "t_pl"}));
  EXPECT_EQ(PlannerParamsFields().Docs()[2].type, "integer");
}

TEST(PlannerParams, FromYamlOverridesDefaultsAndRejectsUnknownKeys) {
  const auto p = PlannerParams::FromYaml(YamlMap::FromString("v_des: 3.5\nn_pol: 6\n", "e.yaml"));
  EXPECT_DOUBLE_EQ(p.v_des, 3.5);
  EXPECT_EQ(p.n_pol, 6);
  EXPECT_DOUBLE_EQ(p.h_pl, PlannerParams{}.h_pl);
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { PlannerParams::FromYaml(YamlMap::FromString("vdes: 3\n", "e.yaml")); }, "vdes",
      {"unknown key; allowed keys"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { PlannerParams::FromYaml(YamlMap::FromString("h_pl: 100\n", "e.yaml")); }, "h_pl",
      {"allowed: a number in [1, 30]"}));
}

}  // namespace
}  // namespace quadtune::planning
