#pragma once
/// \file
/// Options of the obstacle-layout generator: the region, the mission (start/goal), keep-out
/// zones, the density zones with their target spacing, and the obstacle mixture.
///
/// Frame: everything is in the world frame W (z up, ground plane z = 0); lengths in metres,
/// angles in radians.
///
/// Terms used throughout quadtune::layout:
/// - **spacing** s: the paper's "average spacing" (Zhou, Xu, Gao, IROS 2022, Table "various
///   obstacle densities": 3.0, 2.1, 1.3, 0.9 m). What it controls is the density definition:
///   - `area` (default): a fixed NUMBER OF OBSTACLES PER AREA, round(A / (4 s²)) obstacles in a
///     zone of area A (zone x-extent times region y-extent, keep-out zones included). This is
///     the intensity λ = 1 / (4 s²) of the uniform random (Poisson) forest whose expected mean
///     nearest-neighbour distance, 1 / (2 √λ), is s: on average the paper's meaning holds, but
///     the count, hence the crowding, is fixed and grows as 1 / s².
///     Why not one obstacle per s² (λ = 1 / s²)? Measured with the default planner on the
///     shipped forests (docs/results/density/definition.md): A / s² puts 142 obstacles at
///     1.3 m and 296 at 0.9 m into the 240 m² corridor (mean nearest-neighbour distance 0.93
///     and 0.61 m); every default flight there hit obstacles, with 20–25 emergency stops per 3
///     flights, and flight time fell from 1.3 to 0.9 m (65.0 → 60.8 s), so it stops measuring
///     crowding. With A / (4 s²) (7, 14, 36, 74 obstacles) all 40 default flights complete,
///     none with a collision, and the count and the flight time rise monotonically from 3.0 to
///     0.9 m (28.8, 29.0, 32.0, 32.3 s over 10 seeds).
///   - `nearest_neighbour`: darts are added until the mean nearest-neighbour distance between
///     obstacle centres reaches s. At low counts that says little about crowding (a few
///     obstacles spread out reach a large mean with few obstacles).
///   - `free_gap`: darts are added until the mean NEAREST-NEIGHBOUR FREE GAP reaches s: for each
///     obstacle, the distance from its footprint's boundary to the nearest other footprint of
///     its zone, averaged over the zone. It measures the room a drone has between neighbouring
///     surfaces, so one obstacle mix (thick pillars and wide rings) can be crowded to any
///     spacing down to min_gap, and the count rises steeply as the gap closes. The forests of
///     the density study use it (docs/design.md, "Forest density").
///   Every definition measures and reports the achieved nearest-neighbour statistics
///   (LayoutStats). Centres are in the xy-plane: a cylinder's centre is its axis, a ring's the
///   centre of its hole.
/// - **footprint**: an obstacle's projection onto the xy-plane. A cylinder's footprint is its
///   disc; a vertical ring's footprint is the segment its rim covers, thickened by half the rim
///   thickness (a capsule of half-length `radius` across the ring's axis and radius
///   `thickness / 2`).
/// - **non-overlap rule**: the footprints of any two obstacles are at least `min_gap` apart.
///   Footprints apart imply the 3-D bodies are at least as far apart.
///
/// Thread safety: plain values; safe to share read-only between threads.

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/fields_fwd.hpp"

namespace YAML {
class Emitter;
}  // namespace YAML

namespace quadtune::layout {

/// A closed interval [min, max] of a sampled quantity; a value is drawn uniformly from it
/// (min == max gives a constant). YAML: a two-element sequence `[min, max]`.
struct Interval {
  double min = 0.0;  ///< lower bound (unit of the quantity)
  double max = 0.0;  ///< upper bound (unit of the quantity), >= min

  friend bool operator==(const Interval&, const Interval&) = default;
};

/// Shape ranges of the vertical cylinders (pillars) standing on the ground.
/// Defaults follow EGO-Planner's forest generator (radius 0.125–0.525 m).
struct CylinderShape {
  Interval radius{0.125, 0.525};  ///< radius (m), > 0
  Interval height{3.0, 3.0};      ///< top face height above the ground (m), > 0; z_min is 0

  friend bool operator==(const CylinderShape&, const CylinderShape&) = default;
};

/// Shape ranges of the rings (tori standing vertically, horizontal symmetry axis).
/// Defaults follow EGO-Planner's forest generator (radius 0.7–1.2 m).
struct RingShape {
  Interval radius{0.7, 1.2};         ///< major radius (m), > 0
  Interval thickness{0.1, 0.2};      ///< rim diameter (m), > 0 and < 2 * radius.min
  Interval center_height{1.2, 1.8};  ///< height of the hole's centre (m); a ring whose rim
                                     ///< would cut the ground is raised to
                                     ///< radius + thickness / 2 (it then stands on the ground)
  Interval yaw{-0.5, 0.5};           ///< heading of the ring's axis from +x about +z (rad);
                                     ///< yaw 0 faces a flight along +x

  friend bool operator==(const RingShape&, const RingShape&) = default;
};

/// The mixture of obstacles drawn in one zone.
struct ObstacleMix {
  double ring_fraction = 0.2;  ///< probability that a drawn obstacle is a ring, in [0, 1]
  CylinderShape cylinder;      ///< cylinder shape ranges (used when ring_fraction < 1)
  RingShape ring;              ///< ring shape ranges (used when ring_fraction > 0)

  /// Largest footprint reach (m): the farthest a footprint can extend from its centre.
  [[nodiscard]] double MaxReach() const;
  /// Smallest centre distance (m) that two obstacles of this mix may need side by side under
  /// `min_gap`: 2 * max(cylinder radius max, ring thickness max / 2) + min_gap, over the kinds
  /// in use. A target spacing below it cannot be reached.
  [[nodiscard]] double RequiredSpacing(double min_gap) const;

  friend bool operator==(const ObstacleMix&, const ObstacleMix&) = default;
};

/// The axis-aligned rectangle [min_W, max_W] of the xy-plane that holds every footprint.
struct Region {
  Eigen::Vector2d min_W{0.0, -5.0};  ///< lower-left corner (m)
  Eigen::Vector2d max_W{24.0, 5.0};  ///< upper-right corner (m), > min_W component-wise

  /// Area (m²).
  [[nodiscard]] double Area() const { return (max_W - min_W).prod(); }

  friend bool operator==(const Region&, const Region&) = default;
};

/// The flight the layout is made for: start and goal positions (a go-and-return flight flies
/// start → goal → start). Default: a 24 m flight along +x at 1.2 m height.
struct Mission {
  Eigen::Vector3d start_W{0.0, 0.0, 1.2};  ///< start position (m)
  Eigen::Vector3d goal_W{24.0, 0.0, 1.2};  ///< goal position (m)
  double keep_out_radius = 1.5;  ///< radius (m) of the vertical keep-out cylinders around start
                                 ///< and goal; 0 disables them

  friend bool operator==(const Mission&, const Mission&) = default;
};

/// A vertical keep-out cylinder of infinite height (a disc in the xy-plane): no footprint
/// reaches inside it.
struct KeepOutZone {
  Eigen::Vector2d center_W = Eigen::Vector2d::Zero();  ///< axis position (m)
  double radius = 1.0;                                 ///< (m), > 0

  friend bool operator==(const KeepOutZone&, const KeepOutZone&) = default;
};

/// How a spacing turns into a density (see the file comment).
enum class DensityDefinition {
  kArea,              ///< round(zone area / (4 spacing²)) obstacles per zone (YAML `area`)
  kNearestNeighbour,  ///< mean nearest-neighbour distance = spacing (YAML `nearest_neighbour`)
  kFreeGap,           ///< mean nearest-neighbour free gap between footprints = spacing
                      ///< (YAML `free_gap`)
};
constexpr auto EnumNames(DensityDefinition) {
  return std::array{EnumName{DensityDefinition::kArea, "area"},
                    EnumName{DensityDefinition::kNearestNeighbour, "nearest_neighbour"},
                    EnumName{DensityDefinition::kFreeGap, "free_gap"}};
}

/// Most obstacles one layout may ask for (the sum of every zone's count under the `area`
/// definition, or of the Poisson-equivalent count area / (4 spacing²) under
/// `nearest_neighbour`); larger targets are refused by Validate.
inline constexpr double kMaxObstaclesPerLayout = 100000.0;

/// One density zone: the obstacles whose centres lie in x ∈ [x_min, x_max) of the region,
/// generated to reach their own target spacing.
struct ZoneOptions {
  double x_min = 0.0;                    ///< zone start along x (m)
  double x_max = 24.0;                   ///< zone end along x (m), > x_min
  double spacing = 1.3;                  ///< target mean nearest-neighbour spacing (m), > 0
  std::optional<ObstacleMix> obstacles;  ///< this zone's mixture; empty: the layout's

  friend bool operator==(const ZoneOptions&, const ZoneOptions&) = default;
};

/// Everything the generator needs besides the seed. Load with FromYaml; check with Validate.
///
/// YAML (every key optional; unknown keys are errors):
/// ```
/// region:    {min: [0, -5], max: [24, 5]}
/// mission:   {start: [0, 0, 1.2], goal: [24, 0, 1.2], keep_out_radius: 1.5}
/// keep_out:  [{center: [12, 0], radius: 1.0}]
/// spacing: 1.3            # used when `zones` is absent
/// density: area           # area: round(A / (4 spacing²)) obstacles in a zone of area A;
///                         # nearest_neighbour: mean NN distance = spacing;
///                         # free_gap: mean NN free gap between footprints = spacing
/// min_gap: 0.2
/// hard_core_ratio: 0.5
/// tolerance: 0.01
/// max_rejections: 10000
/// ground: true
/// obstacles:
///   ring_fraction: 0.2
///   cylinder: {radius: [0.125, 0.525], height: [3, 3]}
///   ring: {radius: [0.7, 1.2], thickness: [0.1, 0.2], center_height: [1.2, 1.8], yaw: [-0.5, 0.5]}
/// zones:                  # consecutive x-intervals covering the region, each its own density
///   - {x_range: [0, 8], spacing: 3.0}
///   - {x_range: [8, 24], spacing: 1.3, obstacles: {ring_fraction: 0}}
/// ```
struct LayoutOptions {
  Region region;                      ///< where footprints may lie
  Mission mission;                    ///< start/goal and their keep-out cylinders
  std::vector<KeepOutZone> keep_out;  ///< further keep-out cylinders
  double spacing = 1.3;               ///< target spacing (m) when `zones` is empty
  ObstacleMix obstacles;              ///< the obstacle mixture (zones may override it)
  std::vector<ZoneOptions> zones;     ///< density zones; empty: one zone over the region
  double min_gap = 0.2;               ///< least distance (m) between two footprints, >= 0
  double hard_core_ratio = 0.5;       ///< no two centres of a zone closer than this times the
                                      ///< zone's spacing, in (0, 0.9]
  double tolerance = 0.01;            ///< relative tolerance on each zone's achieved spacing
                                      ///< (`nearest_neighbour`, `free_gap`), in (0, 0.1]
  long max_rejections = 10000;        ///< darts rejected in a row before a zone is declared
                                      ///< impossible, in [100, 1e8]
  bool ground = true;                 ///< the world has a ground plane at z = 0
  /// What a spacing means (YAML `density`: area | nearest_neighbour | free_gap).
  DensityDefinition density = DensityDefinition::kArea;

  /// The zones to generate: `zones`, or one zone over the whole region with `spacing`.
  [[nodiscard]] std::vector<ZoneOptions> EffectiveZones() const;
  /// Area (m²) of `zone`: its x-extent times the region's y-extent.
  [[nodiscard]] double ZoneArea(const ZoneOptions& zone) const {
    return (zone.x_max - zone.x_min) * (region.max_W.y() - region.min_W.y());
  }
  /// The obstacle count `zone` is generated to under the `area` definition (and the
  /// Poisson-equivalent count under `nearest_neighbour`): round(ZoneArea / (4 spacing²)), at
  /// least 1. A double, so that absurd targets do not overflow before Validate refuses them.
  [[nodiscard]] double TargetCount(const ZoneOptions& zone) const;
  /// The mixture used in `zone`.
  [[nodiscard]] const ObstacleMix& MixOf(const ZoneOptions& zone) const {
    return zone.obstacles ? *zone.obstacles : obstacles;
  }
  /// Every keep-out cylinder: start and goal (when mission.keep_out_radius > 0), then keep_out.
  [[nodiscard]] std::vector<KeepOutZone> AllKeepOutZones() const;

  /// Throws ConfigError(file, key_prefix + key, ...) on the first bad value: negative or
  /// non-finite sizes, a range with min > max, a spacing smaller than the obstacles allow
  /// (ObstacleMix::RequiredSpacing), a region too small for its obstacles or for the keep-out
  /// zones (their total area above half the region's), zones that are not consecutive
  /// x-intervals covering the region, more than kMaxObstaclesPerLayout obstacles in all
  /// (key `spacing`, or `zones` when zones are given).
  void Validate(const std::string& file = "", const std::string& key_prefix = "") const;

  /// Reads the keys of LayoutFields() (see the struct's documentation), then Validate()s them.
  /// Unknown keys, wrong types and bad values throw ConfigError naming the file and key.
  static LayoutOptions FromYaml(const YamlMap& map);
  /// Reads options from a YAML file (LoadFile + FromYaml); a saved layout (Layout::Save's file)
  /// is refused as such.
  static LayoutOptions LoadFile(const std::string& path);
  /// Writes every field as a YAML map (LayoutFields().Write, doubles with 17 significant
  /// digits), so that FromYaml(ToYaml(o)) == o.
  void ToYaml(YAML::Emitter& out) const;

  friend bool operator==(const LayoutOptions&, const LayoutOptions&) = default;
};

/// The keys of a layout options file: reading, writing and the configuration reference.
const Fields<LayoutOptions>& LayoutFields();
/// The keys of its `region` map.
const Fields<Region>& RegionFields();
/// The keys of its `mission` map.
const Fields<Mission>& MissionFields();
/// The keys of one `keep_out` item.
const Fields<KeepOutZone>& KeepOutFields();
/// The keys of an `obstacles` map (of the layout or of a zone).
const Fields<ObstacleMix>& ObstacleMixFields();
/// The keys of an `obstacles.cylinder` map.
const Fields<CylinderShape>& CylinderShapeFields();
/// The keys of an `obstacles.ring` map.
const Fields<RingShape>& RingShapeFields();
/// The keys of one `zones` item. Its `obstacles` are read over the mixture the zone holds
/// when reading starts (LayoutFields() starts each zone from the layout's mixture).
const Fields<ZoneOptions>& ZoneFields();

}  // namespace quadtune::layout
