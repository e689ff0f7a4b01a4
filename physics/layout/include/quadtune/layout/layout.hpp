#pragma once
/// \file
/// Obstacle layouts: forests of vertical cylinders and rings at a controlled density, made by
/// CGAL-backed dart throwing, saved and loaded as YAML.
///
/// A Layout is a value that fully determines a world's obstacles: the ObstacleSet, the
/// generator options (region, mission start/goal, keep-out zones, density zones) and seed, and
/// the achieved spacing statistics. The physics World is built from `layout.obstacles`.
///
/// Generation (per zone, in zone order, each zone from its own seed stream
/// DeriveSeed(seed, {zone index})):
///  1. draw an obstacle kind (ring with probability ring_fraction) and its shape uniformly
///     from the ranges, then its centre uniformly among the positions in the zone whose
///     footprint lies inside the region;
///  2. reject it when its footprint enters a keep-out cylinder, comes closer than min_gap to
///     any footprint already placed (any zone), or its centre lies closer than
///     hard_core_ratio · spacing to another centre of the zone (Delaunay nearest_vertex);
///  3. density `area`: accept it; stop once the zone holds LayoutOptions::TargetCount
///     obstacles (round(zone area / (4 spacing²))). A zone whose darts are rejected
///     max_rejections times in a row cannot be filled: generation throws ConfigError naming
///     the zone's spacing key, the count placed and the target;
///  4. density `nearest_neighbour`: predict the zone's mean NN spacing with it (from the
///     Delaunay conflict zone: only the new point's Delaunay neighbours change their NN);
///     reject it when the mean would fall below spacing · (1 − tolerance), else accept it; stop
///     once the mean lies within spacing · (1 ± tolerance) and the zone holds at least half
///     the obstacles a Poisson forest of that spacing would hold (so a sparse start that
///     happens to hit the band does not end the zone). max_rejections darts rejected in a row
///     throw ConfigError naming the zone's spacing key.
///  5. density `free_gap`: as 4, with the zone's mean nearest-neighbour free gap between
///     footprints in place of the centre distance (every zone footprint is a candidate
///     neighbour: O(n) per dart), and at least half the obstacles a Poisson forest of centre
///     spacing spacing + the mix's largest reach would hold.
/// Generation never loops forever, and Validate refuses layouts of more than
/// kMaxObstaclesPerLayout obstacles before any dart is thrown.
///
/// Zone statistics measure the NN distances among the zone's own obstacles (as if the zone
/// stood alone); `overall` measures all obstacles together.
///
/// Thread safety: GenerateLayout and the I/O functions are reentrant; a Layout is a value.

#include <cstdint>
#include <string>
#include <vector>

#include "quadtune/common/text_file.hpp"
#include "quadtune/layout/options.hpp"
#include "quadtune/layout/spacing.hpp"
#include "quadtune/physics/obstacles.hpp"

namespace quadtune::layout {

/// What one density zone achieved.
struct ZoneStats {
  double x_min = 0.0;           ///< zone start along x (m)
  double x_max = 0.0;           ///< zone end along x (m)
  double target_spacing = 0.0;  ///< the zone's target spacing (m)
  SpacingStats spacing;         ///< achieved NN statistics among the zone's obstacles (m)
  SpacingStats gap;             ///< achieved NN free-gap statistics among the zone's
                                ///< footprints (m, NearestFreeGaps); measured, not saved
  std::size_t cylinders = 0;    ///< cylinders placed in the zone
  std::size_t rings = 0;        ///< rings placed in the zone
  std::size_t darts = 0;        ///< candidates drawn, accepted or not

  friend bool operator==(const ZoneStats&, const ZoneStats&) = default;
};

/// What a layout achieved: per zone and over all obstacles.
struct LayoutStats {
  SpacingStats overall;          ///< NN statistics over every obstacle centre (m)
  std::vector<ZoneStats> zones;  ///< one per zone, in zone order

  friend bool operator==(const LayoutStats&, const LayoutStats&) = default;
};

/// A generated (or loaded) obstacle layout. Value type.
struct Layout {
  LayoutOptions options;           ///< the generator's options (region, mission, zones …)
  std::uint64_t seed = 0;          ///< the generator's seed
  physics::ObstacleSet obstacles;  ///< the obstacles, world frame W; zone by zone, in the order
                                   ///< placed, cylinders and rings in separate lists
  LayoutStats stats;               ///< achieved spacing statistics

  /// Convenience accessors (m, W).
  [[nodiscard]] const Region& region() const { return options.region; }
  [[nodiscard]] const Eigen::Vector3d& start_W() const { return options.mission.start_W; }
  [[nodiscard]] const Eigen::Vector3d& goal_W() const { return options.mission.goal_W; }

  /// Checks that the layout obeys its own rules: valid options and obstacles, every footprint
  /// inside the region and outside every keep-out cylinder, every pair of footprints at least
  /// options.min_gap apart (1e-9 m slack). Throws ConfigError(file, key, ...) naming the
  /// offending obstacle, e.g. "obstacles.rings[3]".
  void Validate(const std::string& file = "") const;

  /// Writes the layout as YAML (format `quadtune.layout/1`, doubles with 17 significant digits,
  /// so Load(Save(x)) == x bit for bit).
  void ToYaml(YAML::Emitter& out) const;
  /// ToYaml as a string.
  [[nodiscard]] std::string ToYamlString() const;
  /// Writes ToYamlString() to `path`; throws ConfigError(path, "", ...) when it cannot.
  void Save(const std::string& path) const;

  /// Reads a layout from a YAML map and Validate()s it; bad input throws ConfigError.
  static Layout FromYaml(const YamlMap& map);
  /// Reads a layout from YAML text (`origin` names it in errors).
  static Layout FromYamlString(const std::string& text, const std::string& origin = "<string>");
  /// Reads a layout file written by Save; a file past SavedLayoutBounds() or with more than
  /// kMaxObstaclesPerLayout obstacles is refused before any obstacle is read.
  static Layout Load(const std::string& path);

  friend bool operator==(const Layout&, const Layout&) = default;
};

/// The values a saved layout at the obstacle cap holds: at most 12 per obstacle (a ring: its
/// mapping, 4 keys, a 3-list and 6 numbers) and 10 000 for the options and statistics. A larger
/// file is refused while it is parsed, before yaml-cpp builds its nodes.
[[nodiscard]] YamlBounds SavedLayoutBounds();

/// Generates a layout from `options` (Validate()d first) and `seed`. The result depends only on
/// (options, seed): same inputs give bit-identical layouts on every machine.
/// Throws ConfigError for bad options and for a density a zone cannot reach.
[[nodiscard]] Layout GenerateLayout(const LayoutOptions& options, std::uint64_t seed);

/// Recomputes the statistics of `obstacles` under `options`' zones (a centre with x in
/// [x_min, x_max) belongs to that zone; the last zone also takes x == x_max). ZoneStats::darts
/// is left 0.
[[nodiscard]] LayoutStats MeasureLayout(const physics::ObstacleSet& obstacles,
                                        const LayoutOptions& options);

}  // namespace quadtune::layout
