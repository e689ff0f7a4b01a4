#include "quadtune/layout/footprint.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "quadtune/common/cancel.hpp"

namespace quadtune::layout {
namespace {

double Cross(const Eigen::Vector2d& u, const Eigen::Vector2d& v) {
  return u.x() * v.y() - u.y() * v.x();
}

// Distance from p to the segment [a, b] (a == b allowed).
double PointSegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                            const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double len2 = ab.squaredNorm();
  if (len2 <= 0.0) return (p - a).norm();
  const double t = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

// True when the closed segments [a0, a1] and [b0, b1] properly cross (strictly on both sides).
bool SegmentsCross(const Eigen::Vector2d& a0, const Eigen::Vector2d& a1, const Eigen::Vector2d& b0,
                   const Eigen::Vector2d& b1) {
  const double d1 = Cross(a1 - a0, b0 - a0);
  const double d2 = Cross(a1 - a0, b1 - a0);
  const double d3 = Cross(b1 - b0, a0 - b0);
  const double d4 = Cross(b1 - b0, a1 - b0);
  return ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0)) &&
         ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0));
}

}  // namespace

Footprint FootprintOf(const physics::CylinderObstacle& cylinder) {
  return {cylinder.center_W, cylinder.center_W, cylinder.radius};
}

Footprint FootprintOf(const physics::RingObstacle& ring) {
  // The ring lies in the vertical plane normal to its axis (cos yaw, sin yaw, 0); its
  // horizontal in-plane direction is (-sin yaw, cos yaw).
  const Eigen::Vector2d across(-std::sin(ring.yaw), std::cos(ring.yaw));
  const Eigen::Vector2d c = ring.center_W.head<2>();
  return {c - ring.radius * across, c + ring.radius * across, 0.5 * ring.thickness};
}

double SegmentDistance(const Eigen::Vector2d& a0, const Eigen::Vector2d& a1,
                       const Eigen::Vector2d& b0, const Eigen::Vector2d& b1) {
  if (SegmentsCross(a0, a1, b0, b1)) return 0.0;
  // Otherwise the closest pair involves an end point of one of the segments (touching and
  // collinear cases included: an end point then lies on the other segment, distance 0).
  return std::min({PointSegmentDistance(a0, b0, b1), PointSegmentDistance(a1, b0, b1),
                   PointSegmentDistance(b0, a0, a1), PointSegmentDistance(b1, a0, a1)});
}

double FootprintGap(const Footprint& f, const Footprint& g) {
  return SegmentDistance(f.a_W, f.b_W, g.a_W, g.b_W) - f.radius - g.radius;
}

double FootprintGap(const Footprint& f, const Eigen::Vector2d& p_W) {
  return PointSegmentDistance(p_W, f.a_W, f.b_W) - f.radius;
}

std::vector<double> NearestFreeGaps(const std::vector<Footprint>& footprints) {
  const std::size_t n = footprints.size();
  std::vector<double> gaps(n, std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < n; ++i) {
    if (i % 256 == 0) ThrowIfCancelled("free-gap measurement");
    for (std::size_t j = i + 1; j < n; ++j) {
      const double g = FootprintGap(footprints[i], footprints[j]);
      gaps[i] = std::min(gaps[i], g);
      gaps[j] = std::min(gaps[j], g);
    }
  }
  return gaps;
}

}  // namespace quadtune::layout
