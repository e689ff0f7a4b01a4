#pragma once
// Private to quadtune::layout: an incremental CGAL Delaunay triangulation of points in the
// xy-plane, kept behind a pimpl so that CGAL is compiled in spacing.cpp only.
//
// Thread safety: one index per thread (mutable state).

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

namespace quadtune::layout::detail {

class DelaunayIndex {
 public:
  /// A point id (insertion order) with its distance (m) to the query point.
  using Neighbour = std::pair<std::size_t, double>;

  DelaunayIndex();
  ~DelaunayIndex();
  DelaunayIndex(const DelaunayIndex&) = delete;
  DelaunayIndex& operator=(const DelaunayIndex&) = delete;

  /// Number of points inserted.
  [[nodiscard]] std::size_t size() const;
  /// Distance (m) from p to the nearest inserted point; +inf when empty.
  [[nodiscard]] double NearestDistance(const Eigen::Vector2d& p) const;
  /// Fills `out` with every inserted point that would be a Delaunay neighbour of p if p were
  /// inserted (a superset when the triangulation is not yet 2-dimensional: then all points).
  /// p's nearest neighbour, and every point whose nearest neighbour p would become, are in it.
  void PotentialNeighbours(const Eigen::Vector2d& p, std::vector<Neighbour>& out) const;
  /// Inserts p with id size(). p must not coincide with an inserted point.
  void Insert(const Eigen::Vector2d& p);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace quadtune::layout::detail
