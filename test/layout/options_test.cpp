#include "quadtune/layout/options.hpp"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <string>

#include "../config_error_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::layout {
namespace {

LayoutOptions Parse(const std::string& text) {
  return LayoutOptions::FromYaml(YamlMap::FromString(text, "test.yaml"));
}

// Expects a ConfigError whose key is `expected_key` and whose message holds each of the
// remaining arguments (quadtune::test::ThrowsConfigError).
#define EXPECT_CONFIG_ERROR(statement, expected_key, ...) \
  EXPECT_TRUE(                                            \
      quadtune::test::ThrowsConfigError([&] { (void)(statement); }, expected_key, {__VA_ARGS__}))

TEST(LayoutOptions, DefaultsAreValid) {
  const LayoutOptions o;
  EXPECT_NO_THROW(o.Validate());
  ASSERT_EQ(o.EffectiveZones().size(), 1u);
  EXPECT_EQ(o.EffectiveZones()[0].x_min, o.region.min_W.x());
  EXPECT_EQ(o.EffectiveZones()[0].x_max, o.region.max_W.x());
  EXPECT_EQ(o.AllKeepOutZones().size(), 2u);
}

TEST(LayoutOptions, EmptyYamlGivesDefaults) { EXPECT_EQ(Parse("{}"), LayoutOptions{}); }

TEST(LayoutOptions, ReadsEveryKey) {
  const LayoutOptions o = Parse(R"(
region: {min: [-1, -6], max: [30, 6]}
mission: {start: [0, 0, 1.0], goal: [28, 0, 1.5], keep_out_radius: 2.0}
keep_out: [{center: [10, 1], radius: 0.5}]
spacing: 2.5
min_gap: 0.3
hard_core_ratio: 0.4
tolerance: 0.02
max_rejections: 5000
ground: false
density: nearest_neighbour
obstacles:
  ring_fraction: 0.5
  cylinder: {radius: [0.2, 0.3]}
  ring: {yaw: [-1, 1]}
zones:
  - {x_range: [-1, 10], spacing: 3.0}
  - {x_range: [10, 30], spacing: 2.1, obstacles: {ring_fraction: 0}}
)");
  EXPECT_EQ(o.region.min_W, Eigen::Vector2d(-1, -6));
  EXPECT_EQ(o.mission.goal_W, Eigen::Vector3d(28, 0, 1.5));
  EXPECT_EQ(o.mission.keep_out_radius, 2.0);
  ASSERT_EQ(o.keep_out.size(), 1u);
  EXPECT_EQ(o.keep_out[0].radius, 0.5);
  EXPECT_EQ(o.spacing, 2.5);
  EXPECT_EQ(o.min_gap, 0.3);
  EXPECT_EQ(o.hard_core_ratio, 0.4);
  EXPECT_EQ(o.tolerance, 0.02);
  EXPECT_EQ(o.max_rejections, 5000);
  EXPECT_FALSE(o.ground);
  EXPECT_EQ(o.density, DensityDefinition::kNearestNeighbour);
  EXPECT_EQ(o.obstacles.ring_fraction, 0.5);
  EXPECT_EQ(o.obstacles.cylinder.radius, (Interval{0.2, 0.3}));
  EXPECT_EQ(o.obstacles.cylinder.height, CylinderShape{}.height);  // untouched default
  EXPECT_EQ(o.obstacles.ring.yaw, (Interval{-1, 1}));
  ASSERT_EQ(o.zones.size(), 2u);
  EXPECT_FALSE(o.zones[0].obstacles.has_value());
  ASSERT_TRUE(o.zones[1].obstacles.has_value());
  EXPECT_EQ(o.zones[1].obstacles->ring_fraction, 0.0);
  // A zone's override starts from the layout's mixture.
  EXPECT_EQ(o.zones[1].obstacles->cylinder.radius, (Interval{0.2, 0.3}));
  EXPECT_EQ(o.AllKeepOutZones().size(), 3u);
}

TEST(LayoutOptions, YamlRoundTripIsExact) {
  LayoutOptions o;
  o.spacing = 2.0 / 3.0 + 1.0;  // not representable in few digits
  o.density = DensityDefinition::kNearestNeighbour;
  o.region.max_W.x() = 24.1 + 1e-13;
  o.obstacles.ring.yaw = {-0.1234567890123, 0.3};
  o.keep_out.push_back({{5.0 / 3.0, 0.1}, 0.7});
  o.zones.push_back({0.0, 10.0, 3.0, std::nullopt});
  ObstacleMix thin;
  thin.ring_fraction = 0.0;
  thin.cylinder.radius = {0.1, 0.2};
  o.zones.push_back({10.0, o.region.max_W.x(), 0.9, thin});
  ASSERT_NO_THROW(o.Validate());
  YAML::Emitter out;
  o.ToYaml(out);
  EXPECT_EQ(Parse(out.c_str()), o);
}

TEST(LayoutOptions, WrittenFieldsOfShippedAssetsReadBackEqual) {
  for (const char* name : {"forest_thin_1p3.yaml", "changing_density_thin.yaml", "field_40x40.yaml"}) {
    const LayoutOptions o =
        LayoutOptions::LoadFile(std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/" + name);
    YAML::Emitter out;
    SetExactDoubles(out);
    LayoutFields().Write(out, o);
    EXPECT_EQ(Parse(out.c_str()), o) << name;
  }
}

TEST(LayoutOptions, ShippedAssetsAreValid) {
  for (const char* name : {"forest_thin_3p0.yaml", "forest_thin_2p1.yaml", "forest_thin_1p3.yaml",
                           "forest_thin_0p9.yaml", "changing_density_thin.yaml", "field_40x40.yaml"}) {
    EXPECT_NO_THROW(
        LayoutOptions::LoadFile(std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/" + name))
        << name;
  }
}

TEST(LayoutOptions, DensityDefaultsToObstaclesPerArea) {
  EXPECT_EQ(LayoutOptions{}.density, DensityDefinition::kArea);
  EXPECT_EQ(Parse("density: area").density, DensityDefinition::kArea);
  EXPECT_EQ(Parse("density: nearest_neighbour").density, DensityDefinition::kNearestNeighbour);
}

TEST(LayoutOptions, TargetCountIsAreaOverFourSpacingSquared) {
  // 24 x 10 m: 240 / (4 s²) rounded.
  const double expected[][2] = {{3.0, 7.0}, {2.1, 14.0}, {1.3, 36.0}, {0.9, 74.0}, {100.0, 1.0}};
  LayoutOptions o;
  for (const auto& [spacing, count] : expected) {
    const ZoneOptions zone{0.0, 24.0, spacing, std::nullopt};
    EXPECT_EQ(o.TargetCount(zone), count) << spacing;
  }
  // A zone's own area: 6 x 10 m at 1.0 m.
  EXPECT_EQ(o.TargetCount({18.0, 24.0, 1.0, std::nullopt}), 15.0);
}

TEST(LayoutOptions, RejectsUnknownDensityDefinition) {
  try {
    (void)Parse("density: poisson");
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "density");
    const std::string what = e.what();
    EXPECT_NE(what.find("area"), std::string::npos) << what;
    EXPECT_NE(what.find("nearest_neighbour"), std::string::npos) << what;
  }
}

TEST(LayoutOptions, RejectsLayoutThatCouldNeverFinish) {
  // 10^6 x 10^6 m at 1.3 m asks for ~1.5e11 obstacles, far above the limit.
  const std::string huge = "region: {min: [0, -500000], max: [1000000, 500000]}\nspacing: 1.3\n";
  try {
    (void)Parse(huge);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "spacing");
    EXPECT_NE(std::string(e.what()).find("100000"), std::string::npos) << e.what();
  }
  EXPECT_CONFIG_ERROR(Parse(huge + "density: nearest_neighbour"), "spacing",
                      "at most 100000 obstacles");
  EXPECT_CONFIG_ERROR(Parse("region: {min: [0, -500000], max: [1000000, 500000]}\n"
                            "zones: [{x_range: [0, 10], spacing: 3}, "
                            "{x_range: [10, 1000000], spacing: 3}]"),
                      "zones", "at most 100000 obstacles");
  // Just inside the limit: 100 000 obstacles at spacing 1 m (400 000 m²) are accepted.
  EXPECT_NO_THROW(
      Parse("region: {min: [0, 0], max: [400, 1000]}\nspacing: 1.0\n"
            "obstacles: {cylinder: {radius: [0.1, 0.2]}, ring_fraction: 0}\n"
            "mission: {start: [1, 1, 1], goal: [399, 1, 1]}"));
  EXPECT_CONFIG_ERROR(Parse("region: {min: [0, 0], max: [400.01, 1000]}\nspacing: 1.0\n"
                            "obstacles: {cylinder: {radius: [0.1, 0.2]}, ring_fraction: 0}\n"
                            "mission: {start: [1, 1, 1], goal: [399, 1, 1]}"),
                      "spacing", "asks for 100003 obstacles");
}

// --- One EXPECT_THROW per documented bad input. ---

TEST(LayoutOptions, RejectsSpacingSmallerThanObstaclesAllow) {
  // Default pillars up to 0.525 m radius need centres 1.25 m apart with min_gap 0.2.
  EXPECT_CONFIG_ERROR(Parse("spacing: 0.9"), "spacing", "smaller than the obstacles allow",
                      "1.25 m");
}

TEST(LayoutOptions, RejectsZoneSpacingSmallerThanObstaclesAllow) {
  EXPECT_CONFIG_ERROR(Parse(R"(
zones:
  - {x_range: [0, 12], spacing: 2.0}
  - {x_range: [12, 24], spacing: 0.5, obstacles: {cylinder: {radius: [0.1, 0.3]}}}
)"),
                      "zones[1].spacing", "smaller than the obstacles allow", "0.8 m");
}

TEST(LayoutOptions, RejectsRegionTooSmallForKeepOutZones) {
  EXPECT_CONFIG_ERROR(Parse(R"(
region: {min: [0, -2], max: [6, 2]}
mission: {start: [0, 0, 1], goal: [6, 0, 1], keep_out_radius: 2.0}
obstacles: {ring_fraction: 0}
)"),
                      "region", "too small for the keep-out zones");
}

TEST(LayoutOptions, RejectsRegionTooSmallForTheObstacles) {
  EXPECT_CONFIG_ERROR(Parse(R"(
region: {min: [0, -1], max: [24, 1]}
mission: {keep_out_radius: 0}
)"),
                      "region", "too small for the largest obstacle footprint");
}

TEST(LayoutOptions, RejectsInvertedRegion) {
  EXPECT_CONFIG_ERROR(Parse("region: {min: [0, 5], max: [24, -5]}"), "region.max",
                      "must exceed region.min");
}

TEST(LayoutOptions, RejectsNegativeCylinderRadius) {
  EXPECT_CONFIG_ERROR(Parse("obstacles: {cylinder: {radius: [-0.1, 0.3]}}"),
                      "obstacles.cylinder.radius", "got [-0.1, 0.3]");
}

TEST(LayoutOptions, RejectsNegativeRingThickness) {
  EXPECT_CONFIG_ERROR(Parse("obstacles: {ring: {thickness: [-0.1, 0.1]}}"),
                      "obstacles.ring.thickness", "got [-0.1, 0.1]");
}

TEST(LayoutOptions, RejectsNegativeMinGap) {
  EXPECT_CONFIG_ERROR(Parse("min_gap: -0.1"), "min_gap", "got -0.1", "[0, inf)");
}

TEST(LayoutOptions, RejectsNegativeKeepOutRadius) {
  EXPECT_CONFIG_ERROR(Parse("mission: {keep_out_radius: -1}"), "mission.keep_out_radius", "got -1",
                      "[0, inf)");
}

TEST(LayoutOptions, RejectsNonPositiveKeepOutZoneRadius) {
  EXPECT_CONFIG_ERROR(Parse("keep_out: [{center: [3, 0], radius: 0}]"), "keep_out[0].radius",
                      "got 0", "(0, inf)");
}

TEST(LayoutOptions, RejectsNonPositiveSpacing) {
  EXPECT_CONFIG_ERROR(Parse("spacing: 0"), "spacing", "got 0", "(0, inf)");
}

TEST(LayoutOptions, RejectsMinAboveMaxInARange) {
  EXPECT_CONFIG_ERROR(Parse("obstacles: {cylinder: {radius: [0.5, 0.2]}}"),
                      "obstacles.cylinder.radius", "lower bound 0.5 exceeds the upper bound 0.2");
}

TEST(LayoutOptions, RejectsMinAboveMaxInHeightRange) {
  EXPECT_CONFIG_ERROR(Parse("obstacles: {ring: {center_height: [2.0, 1.0]}}"),
                      "obstacles.ring.center_height", "lower bound 2 exceeds the upper bound 1");
}

TEST(LayoutOptions, RejectsRingThickerThanItsHole) {
  EXPECT_CONFIG_ERROR(Parse("obstacles: {ring: {radius: [0.3, 1.0], thickness: [0.1, 0.6]}}"),
                      "obstacles.ring.thickness", "below twice the smallest ring radius");
}

TEST(LayoutOptions, RejectsRingFractionOutsideUnitInterval) {
  EXPECT_CONFIG_ERROR(Parse("obstacles: {ring_fraction: 1.5}"), "obstacles.ring_fraction",
                      "got 1.5", "[0, 1]");
}

TEST(LayoutOptions, RejectsHardCoreRatioOutOfRange) {
  EXPECT_CONFIG_ERROR(Parse("hard_core_ratio: 0.95"), "hard_core_ratio", "got 0.95", "(0, 0.9]");
}

TEST(LayoutOptions, RejectsToleranceOutOfRange) {
  EXPECT_CONFIG_ERROR(Parse("tolerance: 0"), "tolerance", "got 0", "(0, 0.1]");
}

TEST(LayoutOptions, RejectsTooFewMaxRejections) {
  EXPECT_CONFIG_ERROR(Parse("max_rejections: 10"), "max_rejections", "got 10", "[100, 1e+08]");
}

TEST(LayoutOptions, RejectsUnknownTopLevelKey) {
  EXPECT_CONFIG_ERROR(Parse("spacingg: 2.0"), "spacingg", "unknown key", "spacing");
}

TEST(LayoutOptions, RejectsUnknownNestedKey) {
  EXPECT_CONFIG_ERROR(Parse("obstacles: {cylinder: {radius: [0.1, 0.2], colour: red}}"),
                      "obstacles.cylinder.colour", "unknown key", "radius, height");
}

TEST(LayoutOptions, RejectsUnknownZoneKey) {
  EXPECT_CONFIG_ERROR(Parse("zones: [{x_range: [0, 24], spacing: 2, density: 3}]"),
                      "zones[0].density", "unknown key", "x_range, spacing, obstacles");
}

TEST(LayoutOptions, RejectsWrongType) {
  EXPECT_CONFIG_ERROR(Parse("spacing: dense"), "spacing", "'dense' is not a number");
}

TEST(LayoutOptions, RejectsRangeWithoutTwoNumbers) {
  EXPECT_CONFIG_ERROR(Parse("obstacles: {cylinder: {radius: [0.1, 0.2, 0.3]}}"),
                      "obstacles.cylinder.radius", "has 3 entries");
}

TEST(LayoutOptions, RejectsZonesNotStartingAtTheRegion) {
  EXPECT_CONFIG_ERROR(Parse("zones: [{x_range: [2, 24], spacing: 2}]"), "zones[0].x_range",
                      "must start at 0");
}

TEST(LayoutOptions, RejectsZonesWithAGap) {
  EXPECT_CONFIG_ERROR(
      Parse("zones: [{x_range: [0, 10], spacing: 2}, {x_range: [11, 24], spacing: 2}]"),
      "zones[1].x_range", "must start at 10");
}

TEST(LayoutOptions, RejectsZonesNotCoveringTheRegion) {
  EXPECT_CONFIG_ERROR(Parse("zones: [{x_range: [0, 20], spacing: 2}]"), "zones[0].x_range",
                      "must end at 24");
}

TEST(LayoutOptions, RejectsEmptyZone) {
  EXPECT_CONFIG_ERROR(
      Parse("zones: [{x_range: [0, 0], spacing: 2}, {x_range: [0, 24], spacing: 2}]"),
      "zones[0].x_range", "x_min < x_max");
}

TEST(LayoutOptions, ErrorsNameTheFile) {
  try {
    Parse("min_gap: -1");
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), "test.yaml");
    EXPECT_NE(std::string(e.what()).find("min_gap"), std::string::npos);
  }
}

TEST(LayoutOptions, ValidateNamesThePrefixedKey) {
  LayoutOptions o;
  o.min_gap = -1.0;
  EXPECT_CONFIG_ERROR(o.Validate("layout.yaml", "options"), "options.min_gap", "got -1",
                      "[0, inf)");
}

}  // namespace
}  // namespace quadtune::layout
