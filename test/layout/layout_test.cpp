#include "quadtune/layout/layout.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <string>

#include "../config_error_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/layout/footprint.hpp"

namespace quadtune::layout {
namespace {

using quadtune::test::ThrowsConfigError;

using physics::CylinderObstacle;
using physics::RingObstacle;

LayoutOptions Asset(const std::string& name) {
  return LayoutOptions::LoadFile(std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/" + name);
}

// Mean NN distance by brute force, independent of CGAL.
double BruteForceMeanNN(const std::vector<Eigen::Vector2d>& p) {
  double sum = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < p.size(); ++j) {
      if (i != j) best = std::min(best, (p[i] - p[j]).norm());
    }
    sum += best;
  }
  return sum / static_cast<double>(p.size());
}

std::vector<Eigen::Vector2d> Centres(const physics::ObstacleSet& s, double x_min = -1e300,
                                     double x_max = 1e300) {
  std::vector<Eigen::Vector2d> out;
  for (const auto& c : s.cylinders) {
    if (c.center_W.x() >= x_min && c.center_W.x() < x_max) out.push_back(c.center_W);
  }
  for (const auto& r : s.rings) {
    if (r.center_W.x() >= x_min && r.center_W.x() < x_max) out.push_back(r.center_W.head<2>());
  }
  return out;
}

// Points on a ring's surface (W), for checks independent of the footprint code.
std::vector<Eigen::Vector3d> RingSurface(const RingObstacle& r) {
  std::vector<Eigen::Vector3d> pts;
  const Eigen::Vector3d axis = r.Axis_W();
  const Eigen::Vector3d across(-std::sin(r.yaw), std::cos(r.yaw), 0.0);
  for (int i = 0; i < 72; ++i) {
    const double th = 2.0 * std::numbers::pi * i / 72;
    const Eigen::Vector3d dir = std::cos(th) * across + std::sin(th) * Eigen::Vector3d::UnitZ();
    for (int j = 0; j < 12; ++j) {
      const double ph = 2.0 * std::numbers::pi * j / 12;
      pts.push_back(r.center_W + (r.radius + 0.5 * r.thickness * std::cos(ph)) * dir +
                    0.5 * r.thickness * std::sin(ph) * axis);
    }
  }
  return pts;
}

double XyDistanceToCylinder(const Eigen::Vector3d& p, const CylinderObstacle& c) {
  return (p.head<2>() - c.center_W).norm() - c.radius;
}

// Checks the layout's rules without the library's footprint code: pillars by exact geometry,
// rings by sampling their surface. Returns the number of violations (each also reported).
int CountRuleViolations(const Layout& layout) {
  const auto& s = layout.obstacles;
  const double gap = layout.options.min_gap - 1e-9;
  int bad = 0;
  const auto keep_outs = layout.options.AllKeepOutZones();
  const Region& region = layout.options.region;
  auto inside = [&](const Eigen::Vector2d& p, double r) {
    return p.x() - r >= region.min_W.x() - 1e-9 && p.x() + r <= region.max_W.x() + 1e-9 &&
           p.y() - r >= region.min_W.y() - 1e-9 && p.y() + r <= region.max_W.y() + 1e-9;
  };
  for (std::size_t i = 0; i < s.cylinders.size(); ++i) {
    const auto& a = s.cylinders[i];
    if (!inside(a.center_W, a.radius)) ADD_FAILURE() << "cylinder " << i << " outside", ++bad;
    for (const auto& k : keep_outs) {
      if ((a.center_W - k.center_W).norm() - a.radius < k.radius - 1e-9) {
        ADD_FAILURE() << "cylinder " << i << " in a keep-out zone", ++bad;
      }
    }
    for (std::size_t j = i + 1; j < s.cylinders.size(); ++j) {
      const auto& b = s.cylinders[j];
      if ((a.center_W - b.center_W).norm() - a.radius - b.radius < gap) {
        ADD_FAILURE() << "cylinders " << i << " and " << j << " too close", ++bad;
      }
    }
  }
  for (std::size_t i = 0; i < s.rings.size(); ++i) {
    const auto& r = s.rings[i];
    const auto surface = RingSurface(r);
    const Eigen::Vector2d c = r.center_W.head<2>();
    const double reach = r.radius + r.thickness;
    for (const auto& p : surface) {
      if (!inside(p.head<2>(), 0.0)) {
        ADD_FAILURE() << "ring " << i << " outside", ++bad;
        break;
      }
    }
    if (r.center_W.z() - r.radius - 0.5 * r.thickness < -1e-9) {
      ADD_FAILURE() << "ring " << i << " cuts the ground", ++bad;
    }
    for (const auto& k : keep_outs) {
      for (const auto& p : surface) {
        if ((p.head<2>() - k.center_W).norm() < k.radius - 1e-9) {
          ADD_FAILURE() << "ring " << i << " in a keep-out zone", ++bad;
          break;
        }
      }
    }
    for (std::size_t j = 0; j < s.cylinders.size(); ++j) {
      const auto& b = s.cylinders[j];
      if ((c - b.center_W).norm() > reach + b.radius + gap + 0.1) continue;
      for (const auto& p : surface) {
        if (XyDistanceToCylinder(p, b) < gap) {
          ADD_FAILURE() << "ring " << i << " and cylinder " << j << " too close", ++bad;
          break;
        }
      }
    }
    for (std::size_t j = 0; j < s.rings.size(); ++j) {
      const auto& b = s.rings[j];
      if (j == i || (c - b.center_W.head<2>()).norm() > reach + b.radius + b.thickness + 0.5) {
        continue;
      }
      for (const auto& p : surface) {
        if (physics::SignedDistance(b, p) < gap) {
          ADD_FAILURE() << "rings " << i << " and " << j << " too close", ++bad;
          break;
        }
      }
    }
  }
  return bad;
}

// ---------------------------------------------------------------------------------------------
// Density: the paper's four average spacings, 20 seeds each.

class PaperSpacing : public ::testing::TestWithParam<std::pair<const char*, double>> {};

LayoutOptions NearestNeighbour(LayoutOptions o) {
  o.density = DensityDefinition::kNearestNeighbour;
  return o;
}

TEST_P(PaperSpacing, AreaDefinitionPlacesExactlyAreaOverFourSpacingSquared) {
  const auto [asset, target] = GetParam();
  const LayoutOptions options = Asset(asset);
  ASSERT_EQ(options.density, DensityDefinition::kArea);
  // The count from the formula, independent of TargetCount: 240 m² / (4 s²), rounded.
  const auto expected = static_cast<std::size_t>(std::lround(240.0 / (4.0 * target * target)));
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const Layout layout = GenerateLayout(options, seed);
    const auto centres = Centres(layout.obstacles);
    EXPECT_EQ(centres.size(), expected) << asset << " seed " << seed;
    // The nearest-neighbour statistics are still measured and reported.
    ASSERT_EQ(layout.stats.zones.size(), 1u);
    EXPECT_EQ(layout.stats.overall.count, centres.size());
    EXPECT_NEAR(layout.stats.overall.mean, BruteForceMeanNN(centres), 1e-9);
    EXPECT_EQ(layout.stats.zones[0].cylinders + layout.stats.zones[0].rings, expected);
    EXPECT_GE(layout.stats.overall.min, options.hard_core_ratio * target - 1e-12);
    EXPECT_EQ(CountRuleViolations(layout), 0) << asset << " seed " << seed;
    EXPECT_NO_THROW(layout.Validate());
  }
}

TEST_P(PaperSpacing, ReachesTargetWithinThreePercentOverManySeeds) {
  const auto [asset, target] = GetParam();
  const LayoutOptions options = NearestNeighbour(Asset(asset));
  ASSERT_EQ(options.spacing, target);
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const Layout layout = GenerateLayout(options, seed);
    const auto centres = Centres(layout.obstacles);
    const double mean = BruteForceMeanNN(centres);
    EXPECT_NEAR(mean, target, 0.03 * target) << asset << " seed " << seed;
    // The generator aims within its own tolerance (1%), and reports what it achieved.
    EXPECT_NEAR(mean, target, options.tolerance * target + 1e-12) << asset << " seed " << seed;
    ASSERT_EQ(layout.stats.zones.size(), 1u);
    EXPECT_NEAR(layout.stats.zones[0].spacing.mean, mean, 1e-9);
    EXPECT_EQ(layout.stats.zones[0].spacing, layout.stats.overall);
    EXPECT_EQ(layout.stats.overall.count, centres.size());
    EXPECT_GE(layout.stats.overall.min, options.hard_core_ratio * target - 1e-12);
    // Not a handful of obstacles that happen to hit the mean: at least half a Poisson forest.
    const double poisson = options.region.Area() / (4.0 * target * target);
    EXPECT_GE(static_cast<double>(centres.size()), 0.5 * poisson);
    EXPECT_EQ(CountRuleViolations(layout), 0) << asset << " seed " << seed;
    EXPECT_NO_THROW(layout.Validate());
  }
}

INSTANTIATE_TEST_SUITE_P(Layout, PaperSpacing,
                         ::testing::Values(std::make_pair("forest_thin_3p0.yaml", 3.0),
                                           std::make_pair("forest_thin_2p1.yaml", 2.1),
                                           std::make_pair("forest_thin_1p3.yaml", 1.3),
                                           std::make_pair("forest_thin_0p9.yaml", 0.9)),
                         [](const auto& param_info) {
                           return std::to_string(static_cast<int>(param_info.param.second * 10));
                         });

// The density study's forests (density `free_gap`): at every spacing and seed the achieved mean
// nearest-neighbour free gap, re-measured from the obstacles, lies within the options' tolerance
// (1%) of the target; no gap is below min_gap; and the count rises as the gap closes.
TEST(FreeGapForests, AchievedFreeGapMatchesTheTargetAtEveryDensity) {
  double previous_count = 0.0;
  for (const auto& [name, target] : {std::pair{"forest_3p0.yaml", 3.0}, {"forest_2p1.yaml", 2.1},
                                     {"forest_1p3.yaml", 1.3}, {"forest_0p9.yaml", 0.9}}) {
    const LayoutOptions options = Asset(name);
    ASSERT_EQ(options.density, DensityDefinition::kFreeGap) << name;
    double count = 0.0;
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      const Layout layout = GenerateLayout(options, seed);
      std::vector<Footprint> footprints;
      for (const auto& c : layout.obstacles.cylinders) footprints.push_back(FootprintOf(c));
      for (const auto& r : layout.obstacles.rings) footprints.push_back(FootprintOf(r));
      const SpacingStats gap = StatsOf(NearestFreeGaps(footprints));
      EXPECT_NEAR(gap.mean, target, options.tolerance * target) << name << " seed " << seed;
      EXPECT_GE(gap.min, options.min_gap - 1e-9) << name << " seed " << seed;
      EXPECT_DOUBLE_EQ(layout.stats.zones.at(0).gap.mean, gap.mean);
      EXPECT_EQ(CountRuleViolations(layout), 0) << name << " seed " << seed;
      count += static_cast<double>(footprints.size()) / 10.0;
    }
    EXPECT_GT(count, 1.3 * previous_count) << name;
    previous_count = count;
  }
}

// One obstacle mix at every density: the four forests differ only in spacing and min_gap, and
// both kinds appear in every forest in shares near the mix's ring fraction.
TEST(FreeGapForests, ObstacleMixIsTheSameAtEveryDensity) {
  const LayoutOptions reference = Asset("forest_3p0.yaml");
  for (const char* name : {"forest_2p1.yaml", "forest_1p3.yaml", "forest_0p9.yaml"}) {
    const LayoutOptions options = Asset(name);
    EXPECT_EQ(options.obstacles, reference.obstacles) << name;
    EXPECT_DOUBLE_EQ(options.min_gap / options.spacing, reference.min_gap / reference.spacing);
    std::size_t rings = 0;
    std::size_t all = 0;
    for (std::uint64_t seed = 1; seed <= 10; ++seed) {
      const Layout layout = GenerateLayout(options, seed);
      rings += layout.obstacles.rings.size();
      all += layout.obstacles.size();
      for (const auto& c : layout.obstacles.cylinders) {
        EXPECT_GE(c.radius, options.obstacles.cylinder.radius.min);
        EXPECT_LE(c.radius, options.obstacles.cylinder.radius.max);
      }
      for (const auto& r : layout.obstacles.rings) {
        EXPECT_GE(r.radius, options.obstacles.ring.radius.min);
        EXPECT_LE(r.radius, options.obstacles.ring.radius.max);
      }
    }
    const double share = static_cast<double>(rings) / static_cast<double>(all);
    EXPECT_GT(share, 0.25) << name;
    EXPECT_LT(share, 0.6) << name;
  }
}

// A free gap below min_gap cannot be built and is refused naming the key.
TEST(FreeGapForests, GapBelowMinGapIsRefused) {
  LayoutOptions options = Asset("forest_1p3.yaml");
  options.spacing = 0.5 * options.min_gap;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { options.Validate(); }, "spacing",
                                                  {"smaller than min_gap"}));
}

TEST(GenerateLayout, AreaCountHitsItsTargetAcrossSpacingsAndRegionSizes) {
  std::size_t previous = 0;
  for (const double spacing : {4.0, 3.0, 2.1, 1.7, 1.3, 1.1, 0.9}) {
    for (const double width : {12.0, 24.0, 48.0}) {
      for (const double depth : {8.0, 10.0, 20.0}) {
        LayoutOptions o = Asset("forest_thin_0p9.yaml");  // thin pillars fit every spacing here
        o.spacing = spacing;
        o.region.max_W = {width, o.region.min_W.y() + depth};
        o.mission.goal_W.x() = width;
        const double expected = std::max(1.0, std::round(width * depth / (4 * spacing * spacing)));
        const Layout layout = GenerateLayout(o, 3);
        EXPECT_EQ(static_cast<double>(layout.obstacles.size()), expected)
            << spacing << " m over " << width << " x " << depth;
        EXPECT_EQ(CountRuleViolations(layout), 0);
      }
    }
    // Monotone in the spacing: a smaller spacing never holds fewer obstacles.
    LayoutOptions o = Asset("forest_thin_0p9.yaml");
    o.spacing = spacing;
    const std::size_t count = GenerateLayout(o, 1).obstacles.size();
    EXPECT_GT(count, previous) << spacing;
    previous = count;
  }
}

TEST(GenerateLayout, AreaZonesHoldTheirOwnCount) {
  const LayoutOptions options = Asset("changing_density_thin.yaml");
  ASSERT_EQ(options.density, DensityDefinition::kArea);
  const std::size_t expected[] = {3, 18, 7, 37};  // 120 m² / (4 s²) at 3.0, 1.3, 2.1, 0.9 m
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const Layout layout = GenerateLayout(options, seed);
    ASSERT_EQ(layout.stats.zones.size(), 4u);
    for (std::size_t z = 0; z < 4; ++z) {
      const ZoneOptions& zone = options.zones[z];
      const auto centres = Centres(layout.obstacles, zone.x_min, zone.x_max);
      EXPECT_EQ(centres.size(), expected[z]) << "seed " << seed << " zone " << z;
      const ZoneStats& stats = layout.stats.zones[z];
      EXPECT_EQ(stats.cylinders + stats.rings, expected[z]);
      EXPECT_EQ(stats.spacing.count, expected[z]);
      EXPECT_NEAR(stats.spacing.mean, BruteForceMeanNN(centres), 1e-9);
    }
    EXPECT_EQ(CountRuleViolations(layout), 0) << "seed " << seed;
  }
}

TEST(GenerateLayout, ZonesReachTheirOwnSpacing) {
  const LayoutOptions options = NearestNeighbour(Asset("changing_density_thin.yaml"));
  ASSERT_EQ(options.zones.size(), 4u);
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const Layout layout = GenerateLayout(options, seed);
    ASSERT_EQ(layout.stats.zones.size(), options.zones.size());
    std::size_t total = 0;
    for (std::size_t z = 0; z < options.zones.size(); ++z) {
      const ZoneOptions& zone = options.zones[z];
      const auto centres = Centres(layout.obstacles, zone.x_min, zone.x_max);
      const double mean = BruteForceMeanNN(centres);
      EXPECT_NEAR(mean, zone.spacing, 0.03 * zone.spacing) << "seed " << seed << " zone " << z;
      const ZoneStats& stats = layout.stats.zones[z];
      EXPECT_EQ(stats.target_spacing, zone.spacing);
      EXPECT_EQ(stats.spacing.count, centres.size());
      EXPECT_EQ(stats.cylinders + stats.rings, centres.size());
      EXPECT_NEAR(stats.spacing.mean, mean, 1e-9);
      EXPECT_GE(stats.darts, centres.size());
      total += centres.size();
    }
    EXPECT_EQ(total, layout.obstacles.size());
    EXPECT_EQ(layout.stats.overall.count, total);
    // The dense last zone has no rings (its override), and only thin pillars.
    for (const auto& r : layout.obstacles.rings) EXPECT_LT(r.center_W.x(), 36.0);
    for (const auto& c : layout.obstacles.cylinders) {
      if (c.center_W.x() >= 36.0) {
        EXPECT_LE(c.radius, 0.2);
      }
    }
    EXPECT_EQ(CountRuleViolations(layout), 0) << "seed " << seed;
  }
}

TEST(GenerateLayout, DenserZonesHoldMoreObstaclesPerArea) {
  const Layout layout = GenerateLayout(Asset("changing_density_thin.yaml"), 3);
  const auto& z = layout.stats.zones;  // 3.0, 1.3, 2.1, 0.9 m, equal widths
  EXPECT_LT(z[0].spacing.count, z[2].spacing.count);
  EXPECT_LT(z[2].spacing.count, z[1].spacing.count);
  EXPECT_LT(z[1].spacing.count, z[3].spacing.count);
}

TEST(GenerateLayout, LargeFieldReachesTarget) {
  const LayoutOptions options = NearestNeighbour(Asset("field_40x40.yaml"));
  const Layout layout = GenerateLayout(options, 7);
  EXPECT_NEAR(BruteForceMeanNN(Centres(layout.obstacles)), 2.1, 0.03 * 2.1);
  EXPECT_GT(layout.obstacles.rings.size(), 0u);
  EXPECT_EQ(CountRuleViolations(layout), 0);
}

TEST(GenerateLayout, KeepOutZonesAreRespected) {
  LayoutOptions options = Asset("forest_thin_1p3.yaml");
  options.keep_out.push_back({{12.0, 0.0}, 2.0});
  options.keep_out.push_back({{6.0, 3.0}, 1.0});
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    const Layout layout = GenerateLayout(options, seed);
    EXPECT_EQ(CountRuleViolations(layout), 0);
    // Independent check with the physics distance: the keep-out axis is free at flight height.
    for (const auto& k : options.AllKeepOutZones()) {
      for (double z : {0.5, 1.2, 2.0}) {
        EXPECT_GE(layout.obstacles.Distance(Eigen::Vector3d(k.center_W.x(), k.center_W.y(), z)),
                  std::min(z, k.radius) - 1e-9);
      }
    }
  }
}

TEST(GenerateLayout, ShapesStayWithinTheirRanges) {
  const LayoutOptions options = Asset("forest_thin_3p0.yaml");
  const ObstacleMix& mix = options.obstacles;
  std::size_t rings = 0;
  std::size_t cylinders = 0;
  for (std::uint64_t seed = 1; seed <= 10; ++seed) {
    const Layout layout = GenerateLayout(options, seed);
    for (const auto& c : layout.obstacles.cylinders) {
      EXPECT_GE(c.radius, mix.cylinder.radius.min);
      EXPECT_LE(c.radius, mix.cylinder.radius.max);
      EXPECT_EQ(c.z_min, 0.0);
      EXPECT_GE(c.z_max, mix.cylinder.height.min);
      EXPECT_LE(c.z_max, mix.cylinder.height.max);
    }
    for (const auto& r : layout.obstacles.rings) {
      EXPECT_GE(r.radius, mix.ring.radius.min);
      EXPECT_LE(r.radius, mix.ring.radius.max);
      EXPECT_GE(r.thickness, mix.ring.thickness.min);
      EXPECT_LE(r.thickness, mix.ring.thickness.max);
      EXPECT_GE(r.yaw, mix.ring.yaw.min);
      EXPECT_LE(r.yaw, mix.ring.yaw.max);
      EXPECT_GE(r.center_W.z(), mix.ring.center_height.min);
    }
    rings += layout.obstacles.rings.size();
    cylinders += layout.obstacles.cylinders.size();
    EXPECT_NO_THROW(layout.obstacles.Validate());
  }
  EXPECT_GT(rings, 0u);
  EXPECT_GT(cylinders, rings);
}

TEST(GenerateLayout, RingFractionSelectsTheKinds) {
  LayoutOptions options = Asset("forest_thin_3p0.yaml");
  options.obstacles.ring_fraction = 0.0;
  EXPECT_TRUE(GenerateLayout(options, 1).obstacles.rings.empty());
  options.obstacles.ring_fraction = 1.0;
  const Layout rings_only = GenerateLayout(options, 1);
  EXPECT_TRUE(rings_only.obstacles.cylinders.empty());
  EXPECT_GT(rings_only.obstacles.rings.size(), 5u);
  EXPECT_EQ(CountRuleViolations(rings_only), 0);
}

// ---------------------------------------------------------------------------------------------
// Determinism and persistence.

TEST(GenerateLayout, SameSeedGivesIdenticalLayout) {
  const LayoutOptions options = Asset("changing_density_thin.yaml");
  const Layout a = GenerateLayout(options, 42);
  const Layout b = GenerateLayout(options, 42);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a.ToYamlString(), b.ToYamlString());
  const LayoutOptions nn = NearestNeighbour(options);
  EXPECT_EQ(GenerateLayout(nn, 42), GenerateLayout(nn, 42));
}

TEST(GenerateLayout, DifferentSeedGivesDifferentLayout) {
  const LayoutOptions options = Asset("forest_thin_1p3.yaml");
  const Layout a = GenerateLayout(options, 1);
  const Layout b = GenerateLayout(options, 2);
  EXPECT_NE(a.obstacles, b.obstacles);
  EXPECT_FALSE(a == b);
}

TEST(GenerateLayout, ZonesUseIndependentStreams) {
  // Changing the last zone leaves the earlier zones' obstacles untouched.
  LayoutOptions options = Asset("changing_density_thin.yaml");
  const Layout a = GenerateLayout(options, 5);
  options.zones.back().spacing = 1.0;
  const Layout b = GenerateLayout(options, 5);
  auto first_zones = [](const Layout& l) { return Centres(l.obstacles, 0.0, 36.0); };
  EXPECT_EQ(first_zones(a), first_zones(b));
  EXPECT_NE(a.obstacles, b.obstacles);
}

TEST(Layout, SaveLoadIsBitIdentical) {
  const Layout a = GenerateLayout(Asset("changing_density_thin.yaml"), 11);
  const std::filesystem::path path =
      std::filesystem::path(::testing::TempDir()) / "quadtune_layout_roundtrip.yaml";
  a.Save(path.string());
  const Layout b = Layout::Load(path.string());
  EXPECT_EQ(a, b);
  EXPECT_EQ(a.ToYamlString(), b.ToYamlString());
  std::filesystem::remove(path);
  EXPECT_EQ(Layout::FromYamlString(a.ToYamlString()), a);
}

TEST(Layout, SeedRoundTripsAllSixtyFourBits) {
  const Layout a = GenerateLayout(Asset("forest_thin_3p0.yaml"), 0xfedcba9876543210ULL);
  const Layout b = Layout::FromYamlString(a.ToYamlString());
  EXPECT_EQ(b.seed, 0xfedcba9876543210ULL);
  EXPECT_EQ(a, b);
}

TEST(Layout, ShippedLayoutLoadsAndMatchesItsGenerator) {
  const Layout shipped = Layout::Load(std::string(QUADTUNE_SOURCE_DIR) +
                                      "/assets/layouts/forest_1p3_seed1.layout.yaml");
  // Regenerating from the stored options and seed reproduces it bit for bit (on any machine).
  EXPECT_EQ(GenerateLayout(shipped.options, shipped.seed), shipped);
}

TEST(Layout, HandWrittenLayoutGetsMeasuredStats) {
  const Layout l = Layout::FromYamlString(R"(
options: {region: {min: [0, -5], max: [24, 5]}, spacing: 3.0}
obstacles:
  cylinders:
    - {center: [5, 0], radius: 0.3, z_min: 0, z_max: 3}
    - {center: [8, 0], radius: 0.3, z_min: 0, z_max: 3}
  rings:
    - {center: [12, 3, 1.5], yaw: 0, radius: 1.0, thickness: 0.1}
)");
  EXPECT_EQ(l.obstacles.size(), 3u);
  EXPECT_EQ(l.stats.overall.count, 3u);
  EXPECT_NEAR(l.stats.overall.mean, (3.0 + 3.0 + 5.0) / 3.0, 1e-12);  // NN: 3, 3, 5
  EXPECT_EQ(l.seed, 0u);
}

// ---------------------------------------------------------------------------------------------
// Bad layouts and impossible densities.

TEST(Layout, ValidateRejectsOverlappingObstacles) {
  Layout l = GenerateLayout(Asset("forest_thin_2p1.yaml"), 1);
  ASSERT_GE(l.obstacles.cylinders.size(), 2u);
  l.obstacles.cylinders[1].center_W =
      l.obstacles.cylinders[0].center_W + Eigen::Vector2d(l.obstacles.cylinders[0].radius, 0.0);
  EXPECT_TRUE(ThrowsConfigError([&] { l.Validate(); }, "obstacles.cylinders[1]",
                                {"from the footprint of obstacles.cylinders[0]", "min_gap"}));
}

TEST(Layout, ValidateRejectsObstacleInKeepOutZone) {
  Layout l = GenerateLayout(Asset("forest_thin_3p0.yaml"), 1);
  l.obstacles.cylinders.push_back({l.start_W().head<2>() + Eigen::Vector2d(0.5, 0.0), 0.2, 0, 3});
  const std::string key =
      "obstacles.cylinders[" + std::to_string(l.obstacles.cylinders.size() - 1) + "]";
  EXPECT_TRUE(ThrowsConfigError([&] { l.Validate(); }, key, {"enters the keep-out"}));
}

TEST(Layout, ValidateRejectsObstacleOutsideRegion) {
  Layout l = GenerateLayout(Asset("forest_thin_3p0.yaml"), 1);
  l.obstacles.rings.push_back({Eigen::Vector3d(12.0, 4.5, 1.5), 0.0, 1.0, 0.1});
  const std::string key = "obstacles.rings[" + std::to_string(l.obstacles.rings.size() - 1) + "]";
  EXPECT_TRUE(ThrowsConfigError([&] { l.Validate(); }, key, {"leaves the region"}));
}

TEST(Layout, LoadRejectsUnknownKey) {
  EXPECT_TRUE(ThrowsConfigError(
      [] { (void)Layout::FromYamlString("obstacles: {cylinders: [], trees: []}"); },
      "obstacles.trees", {"unknown key", "cylinders"}));
}

TEST(Layout, LoadRejectsWrongFormat) {
  EXPECT_TRUE(ThrowsConfigError([] { (void)Layout::FromYamlString("format: quadtune.layout/99"); },
                                "format", {"quadtune.layout/99", "quadtune.layout/1"}));
}

TEST(Layout, LoadRejectsMissingFile) {
  EXPECT_TRUE(ThrowsConfigError([] { (void)Layout::Load("/nonexistent/quadtune/layout.yaml"); }, "",
                                {"/nonexistent/quadtune/layout.yaml", "no such file"}));
}

TEST(GenerateLayout, UnreachableDensityFailsWithClearError) {
  // Equal pillars that need centres 1.3 m apart cannot average 1.3 m nearest-neighbour spacing:
  // the mean stays above the band and every dart is rejected once the forest saturates.
  LayoutOptions o;
  o.density = DensityDefinition::kNearestNeighbour;
  o.spacing = 1.3;
  o.min_gap = 0.3;
  o.obstacles.ring_fraction = 0.0;
  o.obstacles.cylinder.radius = {0.5, 0.5};
  o.max_rejections = 2000;
  ASSERT_NO_THROW(o.Validate());
  try {
    (void)GenerateLayout(o, 1);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "spacing");
    EXPECT_NE(std::string(e.what()).find("cannot reach"), std::string::npos) << e.what();
  }
}

TEST(GenerateLayout, ZoneCoveredByKeepOutFailsNamingTheZone) {
  LayoutOptions o;
  o.zones = {{0.0, 20.0, 3.0, std::nullopt}, {20.0, 24.0, 3.0, std::nullopt}};
  o.keep_out.push_back({{22.0, 0.0}, 5.5});  // swallows the whole second zone
  o.max_rejections = 500;
  o.mission.keep_out_radius = 0.0;
  ASSERT_NO_THROW(o.Validate());
  try {
    (void)GenerateLayout(o, 1);
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "zones[1].spacing");
    // The area target of zone 1 (40 m² / (4 x 3²) = 1 obstacle) and how many were placed.
    const std::string what = e.what();
    EXPECT_NE(what.find("cannot place the 1 obstacles"), std::string::npos) << what;
    EXPECT_NE(what.find("0 placed"), std::string::npos) << what;
  }
}

TEST(GenerateLayout, InvalidOptionsThrow) {
  LayoutOptions o;
  o.min_gap = -1.0;
  EXPECT_TRUE(ThrowsConfigError([&] { (void)GenerateLayout(o, 1); }, "min_gap", {"-1"}));
}

}  // namespace
}  // namespace quadtune::layout
