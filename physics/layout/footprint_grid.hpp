#pragma once
// Private to quadtune::layout: a uniform grid of footprints, bucketed by centre, for the
// non-overlap test. Cells are at least as large as the largest possible interaction distance
// (two reaches plus min_gap), so the 3x3 cells around a query centre hold every footprint that
// can come within min_gap of it.
//
// Thread safety: one grid per thread (mutable state).

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

#include "quadtune/layout/footprint.hpp"
#include "quadtune/layout/options.hpp"

namespace quadtune::layout::detail {

class FootprintGrid {
 public:
  /// A grid over `region` for footprints of reach at most `max_reach` and the gap `min_gap`.
  FootprintGrid(const Region& region, double max_reach, double min_gap)
      : origin_(region.min_W), min_gap_(min_gap) {
    cell_ = std::max(2.0 * max_reach + min_gap, 1e-3);
    const Eigen::Vector2d size = region.max_W - region.min_W;
    // Keep the grid to a sane number of cells for huge fields with tiny obstacles.
    cell_ = std::max(cell_, std::sqrt(size.prod() / 4.0e6));
    nx_ = static_cast<long>(std::floor(size.x() / cell_)) + 1;
    ny_ = static_cast<long>(std::floor(size.y() / cell_)) + 1;
    cells_.resize(static_cast<std::size_t>(nx_ * ny_));
  }

  /// Index of a stored footprint whose gap to `f` is below min_gap - slack (m), or -1 when
  /// there is none. `f`'s centre must lie in the region.
  [[nodiscard]] long FindConflict(const Footprint& f, double slack = 0.0) const {
    const auto [cx, cy] = CellOf(f.Center());
    for (long y = std::max(cy - 1, 0L); y <= std::min(cy + 1, ny_ - 1); ++y) {
      for (long x = std::max(cx - 1, 0L); x <= std::min(cx + 1, nx_ - 1); ++x) {
        for (const std::size_t i : cells_[static_cast<std::size_t>(y * nx_ + x)]) {
          if (FootprintGap(f, footprints_[i]) < min_gap_ - slack) return static_cast<long>(i);
        }
      }
    }
    return -1;
  }

  /// Stores `f` with index size().
  void Add(const Footprint& f) {
    const auto [cx, cy] = CellOf(f.Center());
    cells_[static_cast<std::size_t>(cy * nx_ + cx)].push_back(footprints_.size());
    footprints_.push_back(f);
  }

  [[nodiscard]] std::size_t size() const { return footprints_.size(); }

 private:
  [[nodiscard]] std::pair<long, long> CellOf(const Eigen::Vector2d& p) const {
    const Eigen::Vector2d q = (p - origin_) / cell_;
    const long x = std::clamp(static_cast<long>(std::floor(q.x())), 0L, nx_ - 1);
    const long y = std::clamp(static_cast<long>(std::floor(q.y())), 0L, ny_ - 1);
    return {x, y};
  }

  Eigen::Vector2d origin_;
  double min_gap_;
  double cell_ = 1.0;
  long nx_ = 1;
  long ny_ = 1;
  std::vector<std::vector<std::size_t>> cells_;
  std::vector<Footprint> footprints_;
};

}  // namespace quadtune::layout::detail
