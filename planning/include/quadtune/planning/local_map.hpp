#pragma once
/// \file
/// A rolling occupancy grid around the drone, built from depth scans (world-frame hit points).
///
/// Cells are cubes of side `resolution` on a global lattice anchored at the world origin: the
/// cell with global index g = (i, j, k) covers [g·res, (g+1)·res) in every axis of the world frame
/// W (z up), so cells line up across window moves. The map stores only a window of N = size/res
/// cells per axis; the storage is a ring buffer (cell g lives at slot g mod N), so moving the
/// window touches only the cells that leave and enter it.
///
/// Each cell holds an occupancy evidence byte (raw occupancy, from hits) and an inflation counter
/// (how many raw-occupied cells lie within `inflation` of it). "Occupied" in the queries below
/// means inflated-occupied unless the name says Raw. Unknown space (never hit, or outside the
/// window) counts as free, as in EGO-Planner. The ground (z below `ground_height`) is an obstacle
/// when `ground_is_obstacle` is set; it is handled analytically and needs no storage.
///
/// Thread safety: const member functions may run concurrently; Insert/MoveTo/Clear need exclusive
/// access. A LocalMap is a copyable value (about 3 bytes per window cell).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/planning/parameters.hpp"

namespace quadtune::planning {

/// Integer index of a cell on the global lattice (see the file comment).
using CellIndex = Eigen::Vector3i;

/// Configuration of a LocalMap.
struct LocalMapOptions {
  double resolution = 0.1;  ///< cell side (m), (0, 1]
  /// Window extent (m) in x, y, z; each at least 2 cells, at most 4096 cells per axis, and at
  /// most 2^27 cells in all. Centred on the point given to the constructor / MoveTo.
  Eigen::Vector3d size = Eigen::Vector3d(12.0, 12.0, 4.0);
  /// Obstacle inflation (m), [0, 15·resolution]: a cell is inflated-occupied when its centre lies
  /// within `inflation` of (the cube of) a raw-occupied cell.
  double inflation = 0.1;
  bool ground_is_obstacle = true;  ///< cells with centre below ground_height are occupied
  double ground_height = 0.0;      ///< height of the ground plane (m), any finite value
  /// Hits farther than this from the sensor origin are ignored (m), > 0 and finite.
  double max_range = 10.0;
  /// Free-space ray clearing: each ray lowers the evidence of the cells it crosses before its hit
  /// cell; a raw-occupied cell is freed after `misses_to_free` misses without a new hit. Costs
  /// a voxel traversal per point (see mapping_bench); static worlds can leave it off.
  bool clear_free_space = false;
  int misses_to_free = 2;  ///< [1, 100]

  /// Resolution and inflation taken from the planner parameters, other fields default.
  static LocalMapOptions FromPlannerParams(const PlannerParams& params);
  /// Throws ConfigError(origin, key, allowed range) for the first bad field.
  void Validate(const std::string& origin = "") const;
  /// Reads the keys of LocalMapFields() over the defaults; validates.
  static LocalMapOptions FromYaml(const YamlMap& map);

  friend bool operator==(const LocalMapOptions&, const LocalMapOptions&) = default;
};

/// The keys of a local map options map.
const Fields<LocalMapOptions>& LocalMapFields();

/// What one LocalMap::Insert did.
struct InsertSummary {
  int points_used = 0;          ///< hits inside the window and within max_range
  int points_out_of_window = 0; ///< hits outside the window (dropped)
  int points_out_of_range = 0;  ///< hits beyond max_range or non-finite (dropped)
  int cells_occupied = 0;       ///< cells that became raw-occupied
  int cells_freed = 0;          ///< cells freed by ray clearing
};

/// The rolling occupancy grid. See the file comment for frames, units and thread safety.
class LocalMap {
 public:
  /// An empty map whose window is centred at center_W (m). Validates `options`.
  explicit LocalMap(const LocalMapOptions& options,
                    const Eigen::Vector3d& center_W = Eigen::Vector3d::Zero());

  /// The options the map was made with.
  [[nodiscard]] const LocalMapOptions& options() const { return options_; }
  /// Cell side (m).
  [[nodiscard]] double resolution() const { return res_; }
  /// Window size in cells.
  [[nodiscard]] const Eigen::Vector3i& window_cells() const { return dims_; }
  /// Global index of the window's lowest cell.
  [[nodiscard]] const CellIndex& window_origin() const { return origin_; }
  /// The window as a world-frame box (m).
  [[nodiscard]] Eigen::AlignedBox3d WindowBox() const;
  /// Inflation radius in cells (inflation / resolution).
  [[nodiscard]] double inflation_cells() const { return infl_cells_; }
  /// Global z index of the lowest cell whose centre is above the ground plane (inflated: above
  /// the inflated ground); cells below it are ground (occupied) when options().ground_is_obstacle.
  [[nodiscard]] int ground_cell_z(bool inflated = false) const {
    return inflated ? ground_cell_inflated_ : ground_cell_;
  }

  /// Moves the window so that it is centred (to the nearest cell) at center_W. Cells that stay
  /// inside keep their state; cells that leave are forgotten. Cost ∝ cells leaving/entering.
  void MoveTo(const Eigen::Vector3d& center_W);

  /// Integrates one depth scan: sensor origin and world-frame hit points (m). Hits inside the
  /// window become raw-occupied (with inflation); with clear_free_space, the cells crossed by
  /// each ray lose evidence first (hits of the same scan win over its misses).
  InsertSummary Insert(const Eigen::Vector3d& origin_W, std::span<const Eigen::Vector3d> hits_W);

  /// Forgets every cell (the window stays where it is).
  void Clear();

  /// Global cell containing p_W (coordinates beyond ±1e8 cells are clamped).
  [[nodiscard]] CellIndex CellOf(const Eigen::Vector3d& p_W) const {
    return {FloorToCell(p_W.x() * inv_res_), FloorToCell(p_W.y() * inv_res_),
            FloorToCell(p_W.z() * inv_res_)};
  }
  /// Centre (m, W) of cell g.
  [[nodiscard]] Eigen::Vector3d CellCenter(const CellIndex& g) const;
  /// Whether cell g is inside the window.
  [[nodiscard]] bool InWindow(const CellIndex& g) const {
    for (int k = 0; k < 3; ++k) {
      const int rel = g[k] - origin_[k];
      if (rel < 0 || rel >= dims_[k]) return false;
    }
    return true;
  }
  /// Whether p_W is inside the window.
  [[nodiscard]] bool InWindow(const Eigen::Vector3d& p_W) const { return InWindow(CellOf(p_W)); }

  /// Inflated occupancy of cell g: ground (inflated) or a raw-occupied cell within `inflation`.
  /// Cells outside the window are free unless below the (inflated) ground.
  [[nodiscard]] bool IsOccupiedCell(const CellIndex& g) const;
  /// Raw occupancy of cell g (hit cells and the ground, no inflation).
  [[nodiscard]] bool IsOccupiedRawCell(const CellIndex& g) const;
  /// Inflated occupancy at p_W (m).
  [[nodiscard]] bool IsOccupied(const Eigen::Vector3d& p_W) const { return IsOccupiedCell(CellOf(p_W)); }
  /// Raw occupancy at p_W (m).
  [[nodiscard]] bool IsOccupiedRaw(const Eigen::Vector3d& p_W) const {
    return IsOccupiedRawCell(CellOf(p_W));
  }

  /// Distance (m) from p_W to the nearest raw-occupied cell (the cell's cube, ground included),
  /// searched within `radius` (m, ≥ 0); returns `radius` when no raw-occupied cell is nearer.
  /// Exact over the cells within radius; cost ∝ the cells of the ball, rows beyond the current
  /// nearest hit skipped.
  [[nodiscard]] double RawClearance(const Eigen::Vector3d& p_W, double radius) const;

  /// Walks the cells the segment a_W→b_W passes through (every cell it touches, corners
  /// included) and returns the fraction t ∈ [0, 1] of the way from a to b at which it enters the
  /// first inflated-occupied cell (0 when a's cell is occupied), or nullopt when it is free.
  [[nodiscard]] std::optional<double> SegmentCollision(const Eigen::Vector3d& a_W,
                                                       const Eigen::Vector3d& b_W,
                                                       bool inflated = true) const;
  /// True when the segment a_W→b_W touches no inflated-occupied cell.
  [[nodiscard]] bool SegmentFree(const Eigen::Vector3d& a_W, const Eigen::Vector3d& b_W) const {
    return !SegmentCollision(a_W, b_W).has_value();
  }

  /// Writes the occupancy of the box of cells [lo, lo + dims) into *out (1 occupied, 0 free),
  /// x fastest, then y, then z (index x + dims.x·(y + dims.y·z)). Ground rules as above, or
  /// without the ground when include_ground is false.
  void ExtractOccupancy(const CellIndex& lo, const Eigen::Vector3i& dims, bool inflated,
                        std::vector<std::uint8_t>* out, bool include_ground = true) const;

  /// Number of raw-occupied cells in the window (O(window) scan; for tests and statistics).
  [[nodiscard]] std::size_t CountRawOccupied() const;
  /// Heap bytes held by the grid.
  [[nodiscard]] std::size_t MemoryBytes() const { return evidence_.size() * 3; }

 private:
  static int FloorToCell(double v) {
    if (!(v >= -1.0e8)) v = -1.0e8;  // also maps NaN to a far cell
    if (v > 1.0e8) v = 1.0e8;
    return static_cast<int>(std::floor(v));
  }
  // Ring-buffer slot of cell g, which must be inside the window.
  [[nodiscard]] std::size_t Slot(const CellIndex& g) const {
    int s[3];
    for (int k = 0; k < 3; ++k) {
      s[k] = g[k] - origin_[k] + ring_offset_[k];
      if (s[k] >= dims_[k]) s[k] -= dims_[k];
    }
    return static_cast<std::size_t>(s[0]) +
           static_cast<std::size_t>(dims_.x()) *
               (static_cast<std::size_t>(s[1]) + static_cast<std::size_t>(dims_.y()) *
                                                     static_cast<std::size_t>(s[2]));
  }
  [[nodiscard]] bool BelowGround(int gz, bool inflated) const;
  template <class Fn>
  void ForEachCell(const CellIndex& lo, const CellIndex& hi, Fn&& fn) const;  // fn(g, slot)
  void MarkOccupied(const CellIndex& g, std::size_t slot);
  void AddInflation(const CellIndex& g, int delta, const CellIndex& lo, const CellIndex& hi);
  void ClearRays(const Eigen::Vector3d& origin_W, std::span<const Eigen::Vector3d> hits_W,
                 InsertSummary* summary);

  LocalMapOptions options_;
  double res_ = 0.1;
  double inv_res_ = 10.0;
  double infl_cells_ = 1.0;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  CellIndex origin_ = CellIndex::Zero();        // global index of the window's lowest cell
  Eigen::Vector3i ring_offset_ = Eigen::Vector3i::Zero();  // origin_ mod dims_
  int ground_cell_ = 0;           // cells with gz < ground_cell_ are below the ground
  int ground_cell_inflated_ = 0;  // cells with gz < this are inflated ground
  std::uint8_t full_evidence_ = 1;
  int ball_r_ = 0;                       // largest |offset| component in ball_
  std::vector<CellIndex> ball_;          // inflation offsets
  std::vector<std::uint8_t> evidence_;   // > 0: raw occupied
  std::vector<std::uint16_t> inflation_; // raw-occupied cells within the inflation ball
};

}  // namespace quadtune::planning
