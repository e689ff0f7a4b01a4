#include "quadtune/optimizers/parameter_space.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "../config_error_util.hpp"

namespace quadtune::optimizers {
namespace {

using quadtune::test::ThrowsWithMessage;

ParameterSpace Mixed() {
  return ParameterSpace::FromYaml(YamlMap::FromString(R"(
parameters:
  - {name: w_col, lower: 0.05, upper: 5.0, log: true, default: 0.5}
  - {name: n_pol, lower: 3, upper: 12, type: integer, default: 5}
  - {name: v_des, lower: 1.0, upper: 6.0}
)"));
}

TEST(ParameterSpace, LoadsFromYaml) {
  const ParameterSpace s = Mixed();
  ASSERT_EQ(s.Dim(), 3);
  EXPECT_EQ(s.At(1).type, ParameterType::kInteger);
  EXPECT_TRUE(s.At(0).log_scale);
  EXPECT_EQ(s.IndexOf("v_des"), 2);
  EXPECT_DOUBLE_EQ(s.Defaults()[0], 0.5);
  EXPECT_DOUBLE_EQ(s.Defaults()[1], 5.0);
  EXPECT_DOUBLE_EQ(s.Defaults()[2], 3.5);  // no default: centre
}

TEST(ParameterSpace, UnitRoundTrip) {
  const ParameterSpace s = Mixed();
  Eigen::VectorXd x(3);
  x << 0.7, 8.0, 2.25;
  const Eigen::VectorXd u = s.ToUnit(x);
  EXPECT_TRUE((u.array() >= 0.0).all() && (u.array() <= 1.0).all());
  EXPECT_NEAR(u[0], (std::log(0.7) - std::log(0.05)) / (std::log(5.0) - std::log(0.05)), 1e-12);
  EXPECT_NEAR(u[1], (8.0 - 3.0 + 0.5) / 10.0, 1e-12);
  EXPECT_NEAR(u[2], 0.25, 1e-12);
  EXPECT_TRUE(s.FromUnit(u).isApprox(x, 1e-12));
}

TEST(ParameterSpace, IntegerCellsAreEquallyWide) {
  const ParameterSpace s = Mixed();
  Eigen::VectorXd u = Eigen::VectorXd::Constant(3, 0.5);
  for (int k = 0; k < 10; ++k) {
    u[1] = (k + 0.01) / 10.0;
    EXPECT_EQ(s.FromUnit(u)[1], 3.0 + k);
    u[1] = (k + 0.99) / 10.0;
    EXPECT_EQ(s.FromUnit(u)[1], 3.0 + k);
  }
  u[1] = 1.0;
  EXPECT_EQ(s.FromUnit(u)[1], 12.0);
  EXPECT_NEAR(s.SnapUnit(u)[1], 0.95, 1e-12);
}

TEST(ParameterSpace, ContainsAndNamed) {
  const ParameterSpace s = Mixed();
  Eigen::VectorXd x(3);
  x << 0.7, 8.0, 2.25;
  EXPECT_TRUE(s.Contains(x));
  x[1] = 8.5;
  EXPECT_FALSE(s.Contains(x));
  const auto named = s.ToNamed(s.Defaults());
  EXPECT_TRUE(s.FromNamed(named).isApprox(s.Defaults()));
  const ParameterSpace sub = s.Subspace({"v_des", "w_col"});
  EXPECT_EQ(sub.Names(), (std::vector<std::string>{"v_des", "w_col"}));
}

TEST(ParameterSpace, RejectsLowerAboveUpper) {
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] {
        ParameterSpace::FromYaml(
            YamlMap::FromString("parameters: [{name: a, lower: 2, upper: 1}]"));
      },
      "parameters[0].upper", {"parameter 'a': upper bound"}));
}

TEST(ParameterSpace, RejectsEmptySpace) {
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { ParameterSpace(std::vector<Parameter>{}); },
                                                  "parameters", {"the parameter space must"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { ParameterSpace::FromYaml(YamlMap::FromString("parameters: []")); }, "parameters",
      {"expected a non-empty sequence"}));
}

TEST(ParameterSpace, RejectsLogScaleWithNonPositiveLower) {
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] {
        ParameterSpace::FromYaml(
            YamlMap::FromString("parameters: [{name: a, lower: 0, upper: 1, log: true}]"));
      },
      "parameters[0].lower", {"parameter 'a': a log-scale"}));
}

TEST(ParameterSpace, RejectsNonIntegerIntegerBounds) {
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] {
        ParameterSpace::FromYaml(
            YamlMap::FromString("parameters: [{name: a, lower: 0.5, upper: 3, type: integer}]"));
      },
      "parameters[0].lower", {"parameter 'a': integer parameter"}));
}

TEST(ParameterSpace, RejectsDefaultOutsideBounds) {
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] {
        ParameterSpace::FromYaml(
            YamlMap::FromString("parameters: [{name: a, lower: 0, upper: 1, default: 2}]"));
      },
      "parameters[0].default", {"parameter 'a': default must"}));
}

TEST(ParameterSpace, RejectsDuplicateNames) {
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] {
        ParameterSpace::FromYaml(YamlMap::FromString(
            "parameters: [{name: a, lower: 0, upper: 1}, {name: a, lower: 0, upper: 2}]"));
      },
      "parameters[1].name", {"duplicate parameter name 'a'"}));
}

TEST(ParameterSpace, RejectsUnknownYamlKey) {
  try {
    (void)ParameterSpace::FromYaml(YamlMap::FromString("parameters: [{name: a, lower: 0, upper: 1, lo: 3}]", "f.yaml"));
    FAIL() << "no throw";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), "f.yaml");
  }
}

TEST(ParameterSpace, RejectsUnknownParameterName) {
  const ParameterSpace s = Mixed();
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { (void)s.IndexOf("nope"); },
                                                       {"unknown parameter 'nope'"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        (void)s.FromNamed({{"nope", 1.0}});
      },
      {"unknown parameter 'nope'"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { (void)s.Subspace({"nope"}); },
                                                       {"unknown parameter 'nope'"}));
}

TEST(ParameterSpace, RejectsWrongVectorSize) {
  const ParameterSpace s = Mixed();
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { (void)s.ToUnit(Eigen::VectorXd::Zero(2)); }, {"expected a vector of size 3", "got 2"}));
  EXPECT_TRUE(
      ThrowsWithMessage<std::invalid_argument>([&] { (void)s.FromUnit(Eigen::VectorXd::Zero(4)); },
                                               {"expected a vector of size 3", "got 4"}));
}

TEST(ParameterSpace, RejectsNaNVector) {
  const ParameterSpace s = Mixed();
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { (void)s.ToUnit(Eigen::VectorXd::Constant(3, std::nan(""))); }, {"NaN"}));
}

}  // namespace
}  // namespace quadtune::optimizers
