#pragma once
/// \file
/// A Euclidean signed distance field (ESDF) over a box of the local map: the snapshot that the
/// trajectory optimiser's collision cost reads through DistanceField.
///
/// Construction: the occupancy of the box's cells is read from the LocalMap (raw occupancy by
/// default); an exact Euclidean distance transform (Felzenszwalb & Huttenlocher, "Distance
/// Transforms of Sampled Functions", 2012: a linear-time lower envelope of parabolas per line,
/// applied along x, then y, then z) gives, for every cell centre, the distance to the nearest
/// occupied cell centre (free cells) or to the nearest free cell centre (occupied cells). When
/// the truncation spans at most ~88 cells (the default 2 m at 0.1 m: 22), the y and z passes
/// instead take the minimum over the truncation window itself, in 16-bit lanes that vectorise:
/// the same values (a site farther than the window lies beyond the truncation) in about 0.45 of
/// the envelope's time (mapping_bench BM_EsdfBuild, the forest box of 186 000 cells). The
/// stored signed distance puts the surface on the cell faces:
///   free cell:      d = (distance to nearest occupied centre − res/2)  > 0
///   occupied cell:  d = −(distance to nearest free centre − res/2)     < 0
/// clamped to ±max_distance and quantised to int16 with a step of max_distance / 16000.
/// Obstacles outside the box are not seen: choose the box with a margin (≥ the clearance) around
/// the path. When the map's ground is an obstacle, it enters analytically: every stored value is
/// min(value, signed height of the cell centre above the ground plane), and the box is extended
/// down by one layer below the ground so that the interpolation reaches it. Occupied cells with a
/// free face neighbour are exactly one cell from free space; only "deep" occupied cells (rare in
/// sensed maps, which hold surfaces) need the transform of the free set, which runs over their
/// bounding box widened by the truncation distance (cells outside the box count as not free).
///
/// Evaluation: trilinear interpolation between the 8 surrounding cell centres; the gradient is the
/// exact derivative of that interpolant (continuous value, piecewise-smooth gradient). In the
/// outer half-cell of the box the value is held constant along the clamped axis (zero gradient
/// component). Outside the box: max_distance with zero gradient.
///
/// Size: sizeof(Esdf) ≈ 100 bytes + 2 bytes per cell; a 10 × 6 × 3 m box at 0.1 m (180 000 cells,
/// 186 000 with the ground layer) is ≈ 0.37 MB per snapshot.
///
/// Thread safety: an immutable value once built; concurrent const calls (Evaluate) are safe.
/// EsdfBuilder holds scratch memory and is not thread-safe: use one per thread.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/planning/distance_field.hpp"
#include "quadtune/planning/local_map.hpp"

namespace quadtune::planning {

/// Configuration of an ESDF build.
struct EsdfOptions {
  /// Truncation distance (m), (0, 30]: distances are exact up to it and clamped beyond; keep it
  /// above PlannerParams::clearance (LocalPlanner refuses a clearance at or above it). Smaller
  /// values make the int16 quantum finer and the build cheaper (the transform's window is
  /// ≈ 2 max_distance / resolution cells). The planner uses distances up to the clearance (0.5 m
  /// by default), so 1 m changes no cost: at the same quantum as 2 m, flights are byte-identical
  /// but where a box lies 1–2 m above the ground (then it gets no ground layer, see above).
  double max_distance = 1.0;
  /// Build from the inflated occupancy instead of the raw hits (distances then measure from the
  /// inflated obstacles).
  bool use_inflated_occupancy = false;

  /// Throws ConfigError(origin, key, allowed range) for the first bad field.
  void Validate(const std::string& origin = "") const;
  /// Reads the keys of EsdfFields() over the defaults; bad values throw ConfigError.
  static EsdfOptions FromYaml(const YamlMap& map);

  friend bool operator==(const EsdfOptions&, const EsdfOptions&) = default;
};

/// The keys of an ESDF options map.
const Fields<EsdfOptions>& EsdfFields();

/// An immutable, copyable ESDF snapshot over a box of cells. See the file comment.
class Esdf final : public DistanceField {
 public:
  /// An empty field: Evaluate returns max_distance (2 m) everywhere with zero gradient.
  Esdf() = default;

  /// Builds the field over the cells of `map` that overlap box_W (m, W). Throws ConfigError for
  /// bad options, std::invalid_argument for an empty/non-finite box or one above 2^26 cells.
  static Esdf Build(const LocalMap& map, const Eigen::AlignedBox3d& box_W,
                    const EsdfOptions& options = {});

  /// Builds the field from an occupancy array (1 = occupied) of dims cells, x fastest (index
  /// x + dims.x·(y + dims.y·z)), whose lowest corner is origin_W (m) and cell side resolution (m).
  static Esdf FromOccupancy(const Eigen::Vector3d& origin_W, double resolution,
                            const Eigen::Vector3i& dims, std::span<const std::uint8_t> occupancy,
                            const EsdfOptions& options = {});

  /// Signed distance (m) at p_W, trilinearly interpolated; d/dp_W into *grad_W when not null.
  double Evaluate(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W) const override;
  /// The C² distance the trajectory optimiser's collision cost reads: the uniform cubic B-spline
  /// over the cell-centre samples (4×4×4 samples around p_W, indices clamped to the box), with its
  /// exact gradient (1) and Hessian (1/m). Being an approximating spline it differs from the
  /// samples by about res²/6 times their second difference (≈ 1 mm at 0.1 m voxels next to a
  /// 0.2 m pillar). Outside the box: max_distance with zero derivatives.
  double EvaluateWithHessian(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W,
                             Eigen::Matrix3d* hess_W) const override;
  /// As EvaluateWithHessian, skipped (false) when every one of the 64 samples it blends is at
  /// least `threshold` (outside the box: when max_distance is): the spline's weights are
  /// nonnegative and sum to one, so it is then at least `threshold` too. The test reads the
  /// samples once (an eighth of an evaluation with derivatives).
  bool EvaluateWithHessianBelow(const Eigen::Vector3d& p_W, double threshold, double* distance,
                                Eigen::Vector3d* grad_W,
                                Eigen::Matrix3d* hess_W) const override;
  /// True: EvaluateWithHessian gives exact curvature of a C² field.
  [[nodiscard]] bool ProvidesCurvature() const override { return true; }

  /// Stored signed distance (m) at the centre of cell idx (local index, 0 ≤ idx < dims()).
  [[nodiscard]] double CellDistance(const Eigen::Vector3i& idx) const;
  /// Centre (m, W) of local cell idx.
  [[nodiscard]] Eigen::Vector3d CellCenter(const Eigen::Vector3i& idx) const;
  /// Whether p_W lies inside the box.
  [[nodiscard]] bool Contains(const Eigen::Vector3d& p_W) const;

  /// The box covered (m, W).
  [[nodiscard]] Eigen::AlignedBox3d box() const {
    return {origin_W_, origin_W_ + dims_.cast<double>() * res_};
  }
  /// Lowest corner of the box (m, W).
  [[nodiscard]] const Eigen::Vector3d& origin() const { return origin_W_; }
  /// Cells per axis.
  [[nodiscard]] const Eigen::Vector3i& dims() const { return dims_; }
  /// Cell side (m).
  [[nodiscard]] double resolution() const { return res_; }
  /// Truncation distance (m).
  [[nodiscard]] double max_distance() const { return max_distance_; }
  /// Quantisation step of the stored distances (m).
  [[nodiscard]] double quantum() const { return quantum_; }
  /// Bytes of this snapshot (object + heap).
  [[nodiscard]] std::size_t MemoryBytes() const {
    return sizeof(Esdf) + values_.capacity() * sizeof(std::int16_t);
  }

 private:
  friend class EsdfBuilder;

  // Contains() for u = (p_W − origin) / resolution, the position in cells.
  [[nodiscard]] bool CoversCells(const Eigen::Vector3d& u) const;

  Eigen::Vector3d origin_W_ = Eigen::Vector3d::Zero();
  Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();
  double res_ = 0.1;
  double inv_res_ = 10.0;
  double max_distance_ = 1.0;
  double quantum_ = 1.0 / 16000.0;
  std::vector<std::int16_t> values_;  // x fastest
};

/// Builds Esdf values, reusing its scratch memory between builds (≈ 5–9 bytes per cell).
///
/// Thread safety: not thread-safe; one builder per thread or task.
class EsdfBuilder {
 public:
  /// See Esdf::Build.
  Esdf Build(const LocalMap& map, const Eigen::AlignedBox3d& box_W,
             const EsdfOptions& options = {});
  /// See Esdf::FromOccupancy.
  Esdf FromOccupancy(const Eigen::Vector3d& origin_W, double resolution,
                     const Eigen::Vector3i& dims, std::span<const std::uint8_t> occupancy,
                     const EsdfOptions& options = {});

 private:
  /// The transform; ground_layer: local z index of the first cell layer above an analytic
  /// ground plane (cells below it are ground), or none.
  Esdf Compute(const Eigen::Vector3d& origin_W, double resolution, const Eigen::Vector3i& dims,
               std::span<const std::uint8_t> occupancy, const EsdfOptions& options,
               std::optional<int> ground_layer);
  /// Compute's inside distances of the occupied cells without a free face neighbour (the
  /// "deep" cells) into `values` (the dims box, x fastest); t_cells: the truncation in cells,
  /// `table`: the quantised distance of each squared cell distance up to t_cells², q_max: the
  /// quantised truncation distance.
  void FillDeepCells(std::span<const std::uint8_t> occupancy, const Eigen::Vector3i& dims,
                     int t_cells, const std::vector<std::int16_t>& table, std::int16_t q_max,
                     std::int16_t* values);
  /// Squared distances (cells²) from every cell of the dims box to the nearest cell whose
  /// occupancy equals `target`; values above `cap` (a squared truncation) may read kInf.
  void SquaredEdt(const std::uint8_t* occupancy, const Eigen::Vector3i& dims, bool target,
                  std::int32_t cap, std::vector<std::int32_t>* out);
  /// The same transform for cap = t_cells² ≤ 8191, by the minimum over the 2·t_cells + 1
  /// neighbours of each line (16-bit, vectorised); equal to the envelope's result.
  void SquaredEdtWindowed(const std::uint8_t* occupancy, const Eigen::Vector3i& dims,
                          bool target, int t_cells, std::vector<std::int32_t>* out);

  std::vector<std::uint8_t> occupancy_;      // box occupancy read from the map
  std::vector<std::uint8_t> sub_occupancy_;  // around the deep occupied cells
  std::vector<std::int32_t> outside_;  // squared cell distances to the nearest occupied centre
  std::vector<std::int32_t> inside_;   // squared cell distances to the nearest free centre
  std::vector<std::int32_t> slab_;     // a transposed slab
  std::vector<std::int16_t> grid16_;   // the windowed transform's values
  std::vector<std::int16_t> plane16_;  // the windowed transform's input rows of one pass
  std::vector<std::uint8_t> live_;     // its chunks of input rows that hold a value below kInf16
  std::vector<std::int32_t> line_d_;
  std::vector<int> hull_v_;
  std::vector<float> hull_fv_;
  std::vector<float> hull_z_;
};

}  // namespace quadtune::planning
