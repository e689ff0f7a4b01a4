#pragma once
/// \file
/// The planner's front end: a collision-free initial path on the inflated local map.
///
/// 1. ChooseLocalGoal: the point at distance h_pl (the planning horizon, PlannerParams::h_pl)
///    from the drone towards the mission goal (the mission goal itself when nearer); if that
///    point is occupied, the nearest free point on the line back towards the drone.
/// 2. PathSearcher::Search: A* over the cells of a search box around start and goal (the
///    start–goal bounding box, widened by search_margin in x and y, spanning [z_min, z_max] in z),
///    26-connected with step costs 1, √2, √3 cells and the 3-D octile distance as heuristic
///    (admissible and consistent, so with heuristic_weight 1 the path is shortest on the lattice).
///    Diagonal steps may not cut corners: every cell a diagonal step touches must be free, so
///    the straight segments between consecutive path cells touch only free cells. Unknown cells
///    and cells outside the map window count as free (EGO-Planner's optimistic assumption).
///    Ties in the open list go to the smaller heuristic, then the smaller cell index, so the
///    result depends only on the map and the inputs.
/// 3. Pruning: greedy line-of-sight shortcutting (LocalMap::SegmentFree) reduces the cell path to
///    a few waypoints — the initial guess for the trajectory optimiser (ResampleByArcLength spreads
///    them over a chosen number of pieces).
///
/// Thread safety: ChooseLocalGoal, PrunePath and ResampleByArcLength are pure functions. A
/// PathSearcher holds reusable scratch memory: one per thread or task; concurrent searches on one
/// const LocalMap from different PathSearchers are safe.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/planning/local_map.hpp"

namespace quadtune::planning {

/// Configuration of the A* front end.
struct PathSearchOptions {
  int max_expansions = 100000;   ///< A* expansions before giving up, [1, 1e8]
  double search_margin = 3.0;    ///< widening of the search box in x and y (m), [0, 50]
  double z_min = 0.2;            ///< lowest cell-centre height searched (m); the start/goal
                                 ///< heights are always included
  double z_max = 3.0;            ///< highest cell-centre height searched (m), > z_min
  double heuristic_weight = 1.0; ///< f = g + w·h, [1, 10]; w > 1 expands fewer cells, and the
                                 ///< path is at most w times longer than the shortest
  double start_escape_radius = 0.3;  ///< an occupied start may step to the nearest free cell
                                     ///< within this radius (m), [0, 2]
  int max_search_cells = 1 << 24;    ///< largest search box (cells), [1, 2^27]

  /// Throws ConfigError(origin, key, allowed range) for the first bad field.
  void Validate(const std::string& origin = "") const;
  /// Reads the keys of PathSearchFields() over the defaults; validates.
  static PathSearchOptions FromYaml(const YamlMap& map);

  friend bool operator==(const PathSearchOptions&, const PathSearchOptions&) = default;
};

/// The keys of a front-end options map.
const Fields<PathSearchOptions>& PathSearchFields();

/// Outcome of a front-end search.
enum class PathSearchStatus {
  kSuccess,            ///< path and waypoints lead from start to goal
  kNoFreeLocalGoal,    ///< every point between the drone and the horizon point is occupied
  kStartOccupied,      ///< the start cell and all cells within start_escape_radius are occupied
  kGoalOccupied,       ///< the goal cell is occupied (use ChooseLocalGoal / Plan)
  kNoPath,             ///< the open list ran empty: start or goal is enclosed, or the way
                       ///< around lies outside the search box (see search_margin)
  kExpansionLimit,     ///< max_expansions reached before the goal
  kSearchBoxTooLarge,  ///< the search box exceeds max_search_cells
};

/// Short names ("success", "no_path", ...), lower_snake as every enum name table.
constexpr auto EnumNames(PathSearchStatus) {
  return std::array{EnumName{PathSearchStatus::kSuccess, "success"},
                    EnumName{PathSearchStatus::kNoFreeLocalGoal, "no_free_local_goal"},
                    EnumName{PathSearchStatus::kStartOccupied, "start_occupied"},
                    EnumName{PathSearchStatus::kGoalOccupied, "goal_occupied"},
                    EnumName{PathSearchStatus::kNoPath, "no_path"},
                    EnumName{PathSearchStatus::kExpansionLimit, "expansion_limit"},
                    EnumName{PathSearchStatus::kSearchBoxTooLarge, "search_box_too_large"}};
}
using quadtune::ToString;

/// Result of PathSearcher::Search / Plan.
struct PathSearchResult {
  PathSearchStatus status = PathSearchStatus::kNoPath;
  std::string message;                   ///< human-readable reason (also on success)
  Eigen::Vector3d start_W = Eigen::Vector3d::Zero();  ///< the start given (m)
  Eigen::Vector3d goal_W = Eigen::Vector3d::Zero();   ///< the (local) goal searched for (m)
  bool goal_is_mission_goal = false;     ///< Plan: the local goal is the mission goal itself
  std::vector<Eigen::Vector3d> path;     ///< cell centres start cell → goal cell (m, W)
  /// Pruned polyline: start_W, a few corner points, goal_W (m, W); empty on failure.
  std::vector<Eigen::Vector3d> waypoints;
  int expansions = 0;                    ///< cells expanded by A*
  double length = 0.0;                   ///< length of `waypoints` (m)

  /// True on kSuccess.
  [[nodiscard]] bool ok() const { return status == PathSearchStatus::kSuccess; }
};

/// A local goal on the line from the drone to the mission goal.
struct LocalGoal {
  bool found = false;            ///< false: every point back to the drone is occupied
  bool is_mission_goal = false;  ///< the mission goal is within h_pl and free
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  ///< the local goal (m, W)
};

/// Chooses the local goal at distance h_pl (m, > 0) from start_W towards mission_goal_W (or the
/// mission goal when nearer); when it is (inflated-)occupied, steps back towards start_W in steps
/// of resolution/2 to the first free point. Throws ConfigError for h_pl ≤ 0 or non-finite input.
[[nodiscard]] LocalGoal ChooseLocalGoal(const LocalMap& map, const Eigen::Vector3d& start_W,
                                        const Eigen::Vector3d& mission_goal_W, double h_pl);

/// Greedy line-of-sight pruning of a polyline on the inflated map: from each kept point, the
/// farthest following point reachable by a free segment before the first blocked one is kept.
/// The first and last points are always kept.
[[nodiscard]] std::vector<Eigen::Vector3d> PrunePath(const LocalMap& map,
                                                     const std::vector<Eigen::Vector3d>& points);

/// n_pieces + 1 points spread evenly by arc length along a polyline (first and last kept);
/// n_pieces ≥ 1, polyline non-empty.
[[nodiscard]] std::vector<Eigen::Vector3d> ResampleByArcLength(
    const std::vector<Eigen::Vector3d>& polyline, int n_pieces);

/// A* front end with reusable scratch memory (≈ 13 bytes per search-box cell).
class PathSearcher {
 public:
  /// Validates `options`.
  explicit PathSearcher(const PathSearchOptions& options = {});

  /// The options in use.
  [[nodiscard]] const PathSearchOptions& options() const { return options_; }

  /// A* from start_W to goal_W (m, W) on the inflated map, then pruning.
  [[nodiscard]] PathSearchResult Search(const LocalMap& map, const Eigen::Vector3d& start_W,
                                        const Eigen::Vector3d& goal_W);

  /// ChooseLocalGoal(map, start_W, mission_goal_W, h_pl), then Search towards it.
  [[nodiscard]] PathSearchResult Plan(const LocalMap& map, const Eigen::Vector3d& start_W,
                                      const Eigen::Vector3d& mission_goal_W, double h_pl);

 private:
  struct SearchBox;  // the cells searched and their local index
  // Steps of Search(), in order.
  [[nodiscard]] SearchBox BoxAround(const LocalMap& map, const CellIndex& start_cell,
                                    const CellIndex& goal_cell) const;
  void ResetCells(std::size_t n_cells);  // sizes the per-cell state, starts a new stamp
  /// Whether the cell (local index `idx`) is occupied; its occupancy is looked up once.
  bool Occupied(const LocalMap& map, const CellIndex& g, int idx);
  bool FreeStartCell(const LocalMap& map, const SearchBox& box, const Eigen::Vector3d& start_W,
                     const CellIndex& start_cell, CellIndex* first);
  PathSearchStatus AStar(const LocalMap& map, const SearchBox& box, const CellIndex& first,
                         const CellIndex& goal_cell, int* expansions);
  void TracePath(const LocalMap& map, const SearchBox& box, int goal_idx,
                 PathSearchResult& result) const;

  PathSearchOptions options_;
  std::uint32_t stamp_ = 0;
  std::vector<std::uint32_t> cell_stamp_;  // cell state valid when == stamp_
  std::vector<float> g_;                   // cost from the start (cells)
  std::vector<std::int32_t> parent_;       // local index of the parent, -1 at the start
  std::vector<std::uint8_t> flags_;        // occupancy known / occupied / closed
};

}  // namespace quadtune::planning
