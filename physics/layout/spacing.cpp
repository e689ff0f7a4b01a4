// The only translation unit of quadtune::layout that includes CGAL (it compiles slowly).
#include "quadtune/layout/spacing.hpp"

#include <CGAL/Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>

#include "quadtune/common/cancel.hpp"

#include "delaunay_index.hpp"
#include "quadtune/common/error.hpp"

namespace quadtune::layout {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_2<std::size_t, Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<VertexBase>;
using Delaunay = CGAL::Delaunay_triangulation_2<Kernel, Tds>;
using CgalPoint = Kernel::Point_2;

CgalPoint ToCgal(const Eigen::Vector2d& p) { return {p.x(), p.y()}; }

double Distance(const CgalPoint& a, const Eigen::Vector2d& b) {
  return std::hypot(a.x() - b.x(), a.y() - b.y());
}

}  // namespace

std::vector<double> NearestNeighbourDistances(const std::vector<Eigen::Vector2d>& points_W) {
  const std::size_t n = points_W.size();
  std::vector<double> nn(n, std::numeric_limits<double>::infinity());
  Delaunay dt;
  Delaunay::Vertex_handle hint;
  for (std::size_t i = 0; i < n; ++i) {
    // SIGINT/SIGTERM (quadtune/common/cancel.hpp): a large layout's insertions take seconds.
    if (i % 1024 == 0) ThrowIfCancelled("layout measurement");
    const std::size_t before = dt.number_of_vertices();
    Delaunay::Vertex_handle v =
        dt.insert(ToCgal(points_W[i]),
                  hint == Delaunay::Vertex_handle() ? Delaunay::Face_handle() : hint->face());
    if (dt.number_of_vertices() == before) {  // coincides with an earlier point
      nn[i] = 0.0;
      nn[v->info()] = 0.0;
    } else {
      v->info() = i;
    }
    hint = v;
  }
  // Every nearest-neighbour pair is a Delaunay edge (also in the 1-dimensional case).
  for (auto e = dt.finite_edges_begin(); e != dt.finite_edges_end(); ++e) {
    const auto va = e->first->vertex(Delaunay::cw(e->second));
    const auto vb = e->first->vertex(Delaunay::ccw(e->second));
    const std::size_t a = va->info();
    const std::size_t b = vb->info();
    const double d = (points_W[a] - points_W[b]).norm();
    nn[a] = std::min(nn[a], d);
    nn[b] = std::min(nn[b], d);
  }
  return nn;
}

SpacingStats StatsOf(const std::vector<double>& distances) {
  SpacingStats s;
  s.count = distances.size();
  if (s.count < 2) return s;
  double sum = 0.0;
  s.min = std::numeric_limits<double>::infinity();
  s.max = -std::numeric_limits<double>::infinity();
  for (double d : distances) {
    sum += d;
    s.min = std::min(s.min, d);
    s.max = std::max(s.max, d);
  }
  s.mean = sum / static_cast<double>(s.count);
  double var = 0.0;
  for (double d : distances) var += (d - s.mean) * (d - s.mean);
  s.std = std::sqrt(var / static_cast<double>(s.count));
  return s;
}

SpacingStats MeasureSpacing(const std::vector<Eigen::Vector2d>& points_W) {
  if (points_W.size() < 2) return SpacingStats{points_W.size()};
  return StatsOf(NearestNeighbourDistances(points_W));
}

namespace detail {

struct DelaunayIndex::Impl {
  Delaunay dt;
  std::vector<Eigen::Vector2d> points;
  std::vector<Delaunay::Vertex_handle> vertices;
  Delaunay::Face_handle hint;            // a face near the last query, to start point location from
  std::vector<Delaunay::Edge> boundary;  // scratch
};

DelaunayIndex::DelaunayIndex() : impl_(std::make_unique<Impl>()) {}
DelaunayIndex::~DelaunayIndex() = default;

std::size_t DelaunayIndex::size() const { return impl_->points.size(); }

double DelaunayIndex::NearestDistance(const Eigen::Vector2d& p) const {
  if (impl_->points.empty()) return std::numeric_limits<double>::infinity();
  const auto v = impl_->dt.nearest_vertex(ToCgal(p), impl_->hint);
  return Distance(v->point(), p);
}

void DelaunayIndex::PotentialNeighbours(const Eigen::Vector2d& p,
                                        std::vector<Neighbour>& out) const {
  out.clear();
  Impl& m = *impl_;
  if (m.dt.dimension() < 2) {
    for (std::size_t i = 0; i < m.points.size(); ++i) {
      out.emplace_back(i, (m.points[i] - p).norm());
    }
    return;
  }
  m.boundary.clear();
  m.dt.get_boundary_of_conflicts(ToCgal(p), std::back_inserter(m.boundary), m.hint);
  for (const Delaunay::Edge& e : m.boundary) {
    for (const int k : {Delaunay::cw(e.second), Delaunay::ccw(e.second)}) {
      const auto v = e.first->vertex(k);
      if (!m.dt.is_infinite(v)) out.emplace_back(v->info(), Distance(v->point(), p));
    }
  }
  // Each vertex of the boundary cycle ends two of its edges: keep it once.
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end(),
                        [](const Neighbour& a, const Neighbour& b) { return a.first == b.first; }),
            out.end());
  QT_DEMAND(!out.empty() || m.points.empty(), "a point in conflict with no finite vertex");
}

void DelaunayIndex::Insert(const Eigen::Vector2d& p) {
  Impl& m = *impl_;
  const std::size_t id = m.points.size();
  const auto v = m.dt.insert(ToCgal(p), m.hint);
  QT_DEMAND(m.dt.number_of_vertices() == id + 1, "DelaunayIndex::Insert of a duplicate point");
  v->info() = id;
  m.points.push_back(p);
  m.vertices.push_back(v);
  m.hint = v->face();
}

}  // namespace detail
}  // namespace quadtune::layout
