#include "quadtune/planning/local_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "quadtune/common/error.hpp"

namespace quadtune::planning {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

int FloorToInt(double v) {
  // Clamp far-away coordinates (and NaN) so the conversion is defined; they land outside every
  // window.
  if (!(v >= -1.0e8)) v = -1.0e8;
  if (v > 1.0e8) v = 1.0e8;
  return static_cast<int>(std::floor(v));
}

int PositiveMod(int a, int n) {
  const int m = a % n;
  return m < 0 ? m + n : m;
}

/// A box of global cells [lo, hi) (hi exclusive).
struct CellBox {
  CellIndex lo;
  CellIndex hi;
  [[nodiscard]] bool Empty() const { return (hi.array() <= lo.array()).any(); }
};

CellBox Intersect(const CellBox& a, const CellBox& b) {
  return {a.lo.cwiseMax(b.lo), a.hi.cwiseMin(b.hi)};
}

/// Decomposes `from` minus `keep` (keep ⊂ from's extent along the shift) into up to three
/// disjoint boxes: cells outside keep in x; then inside in x but outside in y; then inside in
/// x and y but outside in z. `keep` must be the intersection of `from` with another box.
std::vector<CellBox> Difference(const CellBox& from, const CellBox& keep) {
  std::vector<CellBox> out;
  CellIndex lo = from.lo;
  CellIndex hi = from.hi;
  for (int a = 0; a < 3; ++a) {
    if (from.lo[a] < keep.lo[a]) {
      CellBox b{lo, hi};
      b.hi[a] = keep.lo[a];
      if (!b.Empty()) out.push_back(b);
    }
    if (keep.hi[a] < from.hi[a]) {
      CellBox b{lo, hi};
      b.lo[a] = keep.hi[a];
      if (!b.Empty()) out.push_back(b);
    }
    lo[a] = keep.lo[a];
    hi[a] = keep.hi[a];
  }
  return out;
}

/// Voxel traversal (Amanatides & Woo) of the segment a→b on a lattice of cell side res.
/// visit(cell, t_enter) returns false to stop. With `supercover`, where the segment crosses an
/// edge or a corner exactly, the cells touched at that edge/corner are visited too.
template <class Visit>
void Traverse(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double inv_res,
              bool supercover, Visit&& visit) {
  const Eigen::Vector3d ua = a * inv_res;
  const Eigen::Vector3d ub = b * inv_res;
  CellIndex g(FloorToInt(ua.x()), FloorToInt(ua.y()), FloorToInt(ua.z()));
  const CellIndex g_end(FloorToInt(ub.x()), FloorToInt(ub.y()), FloorToInt(ub.z()));
  const Eigen::Vector3d d = ub - ua;
  Eigen::Vector3i step;
  Eigen::Vector3d t_max;
  Eigen::Vector3d t_delta;
  for (int k = 0; k < 3; ++k) {
    if (d[k] > 0.0) {
      step[k] = 1;
      t_delta[k] = 1.0 / d[k];
      t_max[k] = (g[k] + 1 - ua[k]) / d[k];
    } else if (d[k] < 0.0) {
      step[k] = -1;
      t_delta[k] = -1.0 / d[k];
      t_max[k] = (g[k] - ua[k]) / d[k];
    } else {
      step[k] = 0;
      t_delta[k] = kInf;
      t_max[k] = kInf;
    }
  }
  if (!visit(g, 0.0)) return;
  const int max_steps = (g_end - g).cwiseAbs().sum() + 3;
  for (int n = 0; n < max_steps && g != g_end; ++n) {
    const double t = t_max.minCoeff();
    if (t > 1.0) break;
    constexpr double kTie = 1e-9;
    bool tied[3];
    int n_tied = 0;
    for (int k = 0; k < 3; ++k) {
      tied[k] = t_max[k] <= t + kTie && step[k] != 0 && g[k] != g_end[k];
      n_tied += tied[k] ? 1 : 0;
    }
    if (n_tied == 0) break;  // numerical corner case: the end cell is reached along tied axes
    if (supercover && n_tied > 1) {
      // Every cell touching the crossed edge/corner: step each non-empty proper subset of axes.
      for (int mask = 1; mask < 7; ++mask) {
        bool ok = true;
        int count = 0;
        CellIndex c = g;
        for (int k = 0; k < 3; ++k) {
          if ((mask >> k) & 1) {
            if (!tied[k]) ok = false;
            c[k] += step[k];
            ++count;
          }
        }
        if (!ok || count == n_tied) continue;
        if (!visit(c, t)) return;
      }
    }
    for (int k = 0; k < 3; ++k) {
      if (tied[k]) {
        g[k] += step[k];
        t_max[k] += t_delta[k];
      }
    }
    if (!visit(g, t)) return;
  }
}

}  // namespace

// ---------------------------------------------------------------- options

LocalMapOptions LocalMapOptions::FromPlannerParams(const PlannerParams& params) {
  LocalMapOptions o;
  o.resolution = params.map_resolution;
  o.inflation = params.inflation;
  return o;
}

const Fields<LocalMapOptions>& LocalMapFields() {
  using O = LocalMapOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Number("resolution", &O::resolution, {0.0, 1.0, true, false}, "cell side (m)")
          .Vector3("size", &O::size,
                   "window extent in x, y, z (m); each at least 2 and at most 4096 cells, at "
                   "most 2^27 cells in all")
          .Number("inflation", &O::inflation, Range::Any(),
                  "obstacle inflation (m), in [0, 15·`resolution`]")
          .Flag("ground_is_obstacle", &O::ground_is_obstacle,
                "cells with centre below `ground_height` are occupied")
          .Number("ground_height", &O::ground_height, Range::Any(),
                  "height of the ground plane (m)")
          .Number("max_range", &O::max_range, Range::Positive(),
                  "hits farther than this from the sensor origin are ignored (m)")
          .Flag("clear_free_space", &O::clear_free_space,
                "free-space ray clearing: a raw-occupied cell is freed after "
                "`misses_to_free` misses without a new hit")
          .Integer("misses_to_free", &O::misses_to_free, Range::Closed(1, 100),
                   "misses that free a raw-occupied cell");
  return fields;
}

namespace {
// The rules that tie size and inflation to the resolution; `prefix` leads every key.
void CheckWindow(const LocalMapOptions& o, const std::string& file, const std::string& prefix) {
  const double resolution = o.resolution;
  const Eigen::Vector3d& size = o.size;
  const std::string axes[3] = {prefix + "size.x", prefix + "size.y", prefix + "size.z"};
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) {
    CheckInRange(size[k], Range::Closed(2.0 * resolution, 4096.0 * resolution), file, axes[k]);
    cells *= std::round(size[k] / resolution);
  }
  if (cells > static_cast<double>(1 << 27)) {
    throw ConfigError(file, prefix + "size",
                      "the window holds " + std::to_string(cells) +
                          " cells; at most 2^27 are allowed (enlarge resolution or shrink size)");
  }
  CheckInRange(o.inflation, Range::Closed(0.0, 15.0 * resolution), file, prefix + "inflation");
}
}  // namespace

void LocalMapOptions::Validate(const std::string& origin) const {
  LocalMapFields().Check(*this, origin);
  CheckWindow(*this, origin, "");
}

LocalMapOptions LocalMapOptions::FromYaml(const YamlMap& map) {
  const LocalMapOptions o = LocalMapFields().Read(map);
  CheckWindow(o, map.file(), map.path().empty() ? "" : map.path() + ".");
  return o;
}

// ---------------------------------------------------------------- map

LocalMap::LocalMap(const LocalMapOptions& options, const Eigen::Vector3d& center_W)
    : options_(options) {
  options_.Validate();
  res_ = options_.resolution;
  inv_res_ = 1.0 / res_;
  infl_cells_ = options_.inflation / res_;
  for (int k = 0; k < 3; ++k) dims_[k] = static_cast<int>(std::lround(options_.size[k] / res_));
  full_evidence_ = static_cast<std::uint8_t>(options_.clear_free_space ? options_.misses_to_free : 1);

  const int kg = static_cast<int>(std::ceil(options_.ground_height * inv_res_ - 0.5 - 1e-9));
  ground_cell_ = kg;
  ground_cell_inflated_ =
      infl_cells_ >= 0.5 - 1e-9 ? kg + static_cast<int>(std::floor(infl_cells_ - 0.5 + 1e-9)) + 1 : kg;

  // Inflation offsets: cells whose centre is within `inflation` of the occupied cell's cube.
  const int r = static_cast<int>(std::floor(infl_cells_ + 0.5 + 1e-9));
  ball_r_ = r;
  const double r2 = infl_cells_ * infl_cells_ + 1e-9;
  for (int dz = -r; dz <= r; ++dz) {
    for (int dy = -r; dy <= r; ++dy) {
      for (int dx = -r; dx <= r; ++dx) {
        auto excess = [](int v) { return std::max(std::abs(v) - 0.5, 0.0); };
        const double ex = excess(dx);
        const double ey = excess(dy);
        const double ez = excess(dz);
        if (ex * ex + ey * ey + ez * ez <= r2) ball_.emplace_back(dx, dy, dz);
      }
    }
  }

  const std::size_t n = static_cast<std::size_t>(dims_.x()) * dims_.y() * dims_.z();
  evidence_.assign(n, 0);
  inflation_.assign(n, 0);
  origin_ = CellOf(center_W) - dims_ / 2;
  for (int k = 0; k < 3; ++k) ring_offset_[k] = PositiveMod(origin_[k], dims_[k]);
}

Eigen::AlignedBox3d LocalMap::WindowBox() const {
  return {origin_.cast<double>() * res_, (origin_ + dims_).cast<double>() * res_};
}

Eigen::Vector3d LocalMap::CellCenter(const CellIndex& g) const {
  return (g.cast<double>().array() + 0.5).matrix() * res_;
}

bool LocalMap::BelowGround(int gz, bool inflated) const {
  return options_.ground_is_obstacle && gz < (inflated ? ground_cell_inflated_ : ground_cell_);
}

bool LocalMap::IsOccupiedCell(const CellIndex& g) const {
  if (BelowGround(g.z(), true)) return true;
  if (!InWindow(g)) return false;
  return inflation_[Slot(g)] > 0;
}

bool LocalMap::IsOccupiedRawCell(const CellIndex& g) const {
  if (BelowGround(g.z(), false)) return true;
  if (!InWindow(g)) return false;
  return evidence_[Slot(g)] > 0;
}

double LocalMap::RawClearance(const Eigen::Vector3d& p_W, double radius) const {
  const int r = static_cast<int>(std::ceil(radius * inv_res_));
  const CellIndex c = CellOf(p_W);
  const int span = 2 * r + 1;
  // Squared distance from p_W to the slab of cell c[k] + d along axis k, d = -r..r.
  std::vector<double> axis2(3 * static_cast<std::size_t>(span));
  for (int k = 0; k < 3; ++k) {
    for (int d = -r; d <= r; ++d) {
      const double lo = (c[k] + d) * res_, hi = lo + res_;
      const double gap = p_W[k] < lo ? lo - p_W[k] : (p_W[k] > hi ? p_W[k] - hi : 0.0);
      axis2[static_cast<std::size_t>(k * span + d + r)] = gap * gap;
    }
  }
  const double* x2 = axis2.data();
  const double* y2 = x2 + span;
  const double* z2 = y2 + span;
  double best2 = radius * radius;
  for (int dz = -r; dz <= r; ++dz) {
    const int gz = c.z() + dz;
    const double zz = z2[dz + r];
    if (zz >= best2) continue;
    const bool ground = BelowGround(gz, false);
    const bool z_in = gz >= origin_.z() && gz < origin_.z() + dims_.z();
    if (!ground && !z_in) continue;
    for (int dy = -r; dy <= r; ++dy) {
      const int gy = c.y() + dy;
      const double yy = y2[dy + r];
      if (yy + zz >= best2) continue;
      const bool y_in = gy >= origin_.y() && gy < origin_.y() + dims_.y();
      if (!ground && !y_in) continue;
      if (ground) {
        for (int dx = -r; dx <= r; ++dx) best2 = std::min(best2, x2[dx + r] + yy + zz);
        continue;
      }
      // Ring-buffer slots of the row (y, z fixed), as Slot() computes them.
      int sy = gy - origin_.y() + ring_offset_.y();
      if (sy >= dims_.y()) sy -= dims_.y();
      int sz = gz - origin_.z() + ring_offset_.z();
      if (sz >= dims_.z()) sz -= dims_.z();
      const std::uint8_t* row =
          evidence_.data() + static_cast<std::size_t>(dims_.x()) *
                                 (static_cast<std::size_t>(sy) +
                                  static_cast<std::size_t>(dims_.y()) * static_cast<std::size_t>(sz));
      for (int dx = -r; dx <= r; ++dx) {
        const double d2 = x2[dx + r] + yy + zz;
        if (d2 >= best2) continue;
        const int rel = c.x() + dx - origin_.x();
        if (rel < 0 || rel >= dims_.x()) continue;
        int sx = rel + ring_offset_.x();
        if (sx >= dims_.x()) sx -= dims_.x();
        if (row[sx] > 0) best2 = d2;
      }
    }
  }
  return std::sqrt(best2);
}

void LocalMap::AddInflation(const CellIndex& g, int delta, const CellIndex& lo,
                            const CellIndex& hi) {
  // Per-axis slots of the ball's extent (-1 outside [lo, hi)), then combine.
  const int r = ball_r_;
  int slots[3][64];
  for (int k = 0; k < 3; ++k) {
    for (int d = -r; d <= r; ++d) {
      const int c = g[k] + d;
      int s = -1;
      if (c >= lo[k] && c < hi[k]) {
        s = c - origin_[k] + ring_offset_[k];
        if (s >= dims_[k]) s -= dims_[k];
      }
      slots[k][d + r] = s;
    }
  }
  const std::size_t nx = static_cast<std::size_t>(dims_.x());
  const std::size_t nxy = nx * static_cast<std::size_t>(dims_.y());
  for (const CellIndex& off : ball_) {
    const int sx = slots[0][off.x() + r];
    const int sy = slots[1][off.y() + r];
    const int sz = slots[2][off.z() + r];
    if (sx < 0 || sy < 0 || sz < 0) continue;
    std::uint16_t& v = inflation_[static_cast<std::size_t>(sx) + nx * static_cast<std::size_t>(sy) +
                                  nxy * static_cast<std::size_t>(sz)];
    v = static_cast<std::uint16_t>(v + delta);
  }
}

void LocalMap::MarkOccupied(const CellIndex& g, std::size_t slot) {
  if (evidence_[slot] == 0) AddInflation(g, +1, origin_, origin_ + dims_);
  evidence_[slot] = full_evidence_;
}

void LocalMap::Clear() {
  std::fill(evidence_.begin(), evidence_.end(), 0);
  std::fill(inflation_.begin(), inflation_.end(), 0);
}

template <class Fn>
void LocalMap::ForEachCell(const CellIndex& lo, const CellIndex& hi, Fn&& fn) const {
  // Per-axis ring coordinates of the box (each wraps at most once), combined per cell.
  std::vector<std::size_t> axis[3];
  for (int k = 0; k < 3; ++k) {
    int s = lo[k] - origin_[k] + ring_offset_[k];
    if (s >= dims_[k]) s -= dims_[k];
    for (int c = lo[k]; c < hi[k]; ++c) {
      axis[k].push_back(static_cast<std::size_t>(s));
      if (++s == dims_[k]) s = 0;
    }
  }
  const std::size_t nx = static_cast<std::size_t>(dims_.x());
  const std::size_t nxy = nx * static_cast<std::size_t>(dims_.y());
  for (int z = lo.z(); z < hi.z(); ++z) {
    const std::size_t sz = axis[2][static_cast<std::size_t>(z - lo.z())] * nxy;
    for (int y = lo.y(); y < hi.y(); ++y) {
      const std::size_t szy = sz + axis[1][static_cast<std::size_t>(y - lo.y())] * nx;
      for (int x = lo.x(); x < hi.x(); ++x) {
        fn(CellIndex(x, y, z), szy + axis[0][static_cast<std::size_t>(x - lo.x())]);
      }
    }
  }
}

void LocalMap::MoveTo(const Eigen::Vector3d& center_W) {
  const CellIndex new_origin = CellOf(center_W) - dims_ / 2;
  if (new_origin == origin_) return;
  const CellIndex shift = new_origin - origin_;
  auto set_origin = [&] {
    origin_ = new_origin;
    for (int k = 0; k < 3; ++k) ring_offset_[k] = PositiveMod(origin_[k], dims_[k]);
  };
  if ((shift.cwiseAbs().array() >= dims_.array()).any()) {
    Clear();
    set_origin();
    return;
  }
  const CellBox old_box{origin_, origin_ + dims_};
  const CellBox new_box{new_origin, new_origin + dims_};
  const CellBox keep = Intersect(old_box, new_box);

  // 1. Cells leaving: withdraw their inflation from the cells that stay, then forget them.
  for (const CellBox& b : Difference(old_box, keep)) {
    ForEachCell(b.lo, b.hi, [&](const CellIndex& g, std::size_t s) {
      if (evidence_[s] > 0) AddInflation(g, -1, keep.lo, keep.hi);
      evidence_[s] = 0;
      inflation_[s] = 0;
    });
  }
  // 2. The freed slots now belong to the entering cells.
  set_origin();
  // 3. Entering cells: add the inflation of the kept occupied cells near them.
  const int r = ball_r_;
  const CellIndex pad = CellIndex::Constant(r);
  for (const CellBox& e : Difference(new_box, keep)) {
    const CellBox band = Intersect(CellBox{e.lo - pad, e.hi + pad}, keep);
    if (band.Empty() || r == 0) continue;
    ForEachCell(band.lo, band.hi, [&](const CellIndex& g, std::size_t s) {
      if (evidence_[s] > 0) AddInflation(g, +1, e.lo, e.hi);
    });
  }
}

void LocalMap::ClearRays(const Eigen::Vector3d& origin_W, std::span<const Eigen::Vector3d> hits_W,
                         InsertSummary* summary) {
  const CellIndex lo = origin_;
  const CellIndex hi = origin_ + dims_;
  for (const Eigen::Vector3d& hit : hits_W) {
    if (!hit.allFinite()) continue;
    Eigen::Vector3d end = hit;
    const double range = (hit - origin_W).norm();
    bool clip = false;
    if (range > options_.max_range) {
      end = origin_W + (hit - origin_W) * (options_.max_range / range);
      clip = true;
    }
    const CellIndex hit_cell = CellOf(end);
    bool entered = false;
    Traverse(origin_W, end, inv_res_, false, [&](const CellIndex& g, double) {
      if (!clip && g == hit_cell) return false;
      bool inside = true;
      for (int k = 0; k < 3; ++k) inside = inside && g[k] >= lo[k] && g[k] < hi[k];
      if (!inside) return !entered;  // the window is convex: once left, done
      entered = true;
      const std::size_t s = Slot(g);
      if (evidence_[s] > 0 && --evidence_[s] == 0) {
        AddInflation(g, -1, lo, hi);
        ++summary->cells_freed;
      }
      return true;
    });
  }
}

InsertSummary LocalMap::Insert(const Eigen::Vector3d& origin_W,
                               std::span<const Eigen::Vector3d> hits_W) {
  InsertSummary summary;
  if (options_.clear_free_space && origin_W.allFinite()) ClearRays(origin_W, hits_W, &summary);
  const double max_r2 = options_.max_range * options_.max_range;
  for (const Eigen::Vector3d& hit : hits_W) {
    if (!hit.allFinite() || (hit - origin_W).squaredNorm() > max_r2) {
      ++summary.points_out_of_range;
      continue;
    }
    const CellIndex g = CellOf(hit);
    if (!InWindow(g)) {
      ++summary.points_out_of_window;
      continue;
    }
    ++summary.points_used;
    const std::size_t s = Slot(g);
    if (evidence_[s] == 0) ++summary.cells_occupied;
    MarkOccupied(g, s);
  }
  return summary;
}

std::optional<double> LocalMap::SegmentCollision(const Eigen::Vector3d& a_W,
                                                 const Eigen::Vector3d& b_W, bool inflated) const {
  std::optional<double> result;
  Traverse(a_W, b_W, inv_res_, true, [&](const CellIndex& g, double t) {
    if (inflated ? IsOccupiedCell(g) : IsOccupiedRawCell(g)) {
      result = t;
      return false;
    }
    return true;
  });
  return result;
}

void LocalMap::ExtractOccupancy(const CellIndex& lo, const Eigen::Vector3i& dims, bool inflated,
                                std::vector<std::uint8_t>* out, bool include_ground) const {
  QT_DEMAND(out != nullptr && (dims.array() >= 0).all(), "ExtractOccupancy: bad arguments");
  const std::size_t nx = static_cast<std::size_t>(dims.x());
  out->assign(nx * static_cast<std::size_t>(dims.y()) * static_cast<std::size_t>(dims.z()), 0);
  // The x-range of the box that lies inside the window, split where the ring wraps.
  const int x0 = std::max(lo.x(), origin_.x());
  const int x1 = std::min(lo.x() + dims.x(), origin_.x() + dims_.x());
  for (int z = 0; z < dims.z(); ++z) {
    const int gz = lo.z() + z;
    const bool ground = include_ground && BelowGround(gz, inflated);
    const bool z_in = gz >= origin_.z() && gz < origin_.z() + dims_.z();
    for (int y = 0; y < dims.y(); ++y) {
      std::uint8_t* row = out->data() + nx * (static_cast<std::size_t>(y) +
                                              static_cast<std::size_t>(dims.y()) * z);
      if (ground) {
        std::fill(row, row + nx, 1);
        continue;
      }
      const int gy = lo.y() + y;
      if (!z_in || gy < origin_.y() || gy >= origin_.y() + dims_.y() || x0 >= x1) continue;
      const std::size_t base = Slot(CellIndex(x0, gy, gz));
      std::size_t sx = base % static_cast<std::size_t>(dims_.x());
      const std::size_t row_start = base - sx;
      for (int x = x0; x < x1; ++x) {
        const std::size_t s = row_start + sx;
        row[x - lo.x()] = inflated ? (inflation_[s] > 0) : (evidence_[s] > 0);
        if (++sx == static_cast<std::size_t>(dims_.x())) sx = 0;
      }
    }
  }
}

std::size_t LocalMap::CountRawOccupied() const {
  return static_cast<std::size_t>(
      std::count_if(evidence_.begin(), evidence_.end(), [](std::uint8_t e) { return e > 0; }));
}

}  // namespace quadtune::planning
