#include "quadtune/physics/ray_caster.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::physics {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Real roots of x³ + a x² + b x + c (1 or 3 of them, unsorted).
int SolveCubic(double a, double b, double c, double roots[3]) {
  const double q = (a * a - 3.0 * b) / 9.0;
  const double r = (2.0 * a * a * a - 9.0 * a * b + 27.0 * c) / 54.0;
  const double q3 = q * q * q;
  if (r * r < q3) {
    const double theta = std::acos(std::clamp(r / std::sqrt(q3), -1.0, 1.0));
    const double m = -2.0 * std::sqrt(q);
    roots[0] = m * std::cos(theta / 3.0) - a / 3.0;
    roots[1] = m * std::cos((theta + 2.0 * std::numbers::pi) / 3.0) - a / 3.0;
    roots[2] = m * std::cos((theta - 2.0 * std::numbers::pi) / 3.0) - a / 3.0;
    return 3;
  }
  const double big = -std::copysign(std::cbrt(std::abs(r) + std::sqrt(r * r - q3)), r);
  const double small = big != 0.0 ? q / big : 0.0;
  roots[0] = big + small - a / 3.0;
  return 1;
}

// First intersection of the unit ray o + t d (t in [0, t_max]) with the torus of major radius
// R and minor radius r about the local z-axis, centred at the origin.
double IntersectTorusLocal(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double R, double r,
                           double t_max) {
  // Clip to the bounding sphere and the slab |z| <= r.
  const double rb = R + r;
  const double b0 = o.dot(d);
  const double disc = b0 * b0 - (o.squaredNorm() - rb * rb);
  if (disc < 0.0) return kInf;
  const double sq = std::sqrt(disc);
  double t_start = std::max(0.0, -b0 - sq);
  double t_end = std::min(t_max, -b0 + sq);
  if (std::abs(d.z()) > 1e-12) {
    double tz0 = (-r - o.z()) / d.z();
    double tz1 = (r - o.z()) / d.z();
    if (tz0 > tz1) std::swap(tz0, tz1);
    t_start = std::max(t_start, tz0);
    t_end = std::min(t_end, tz1);
  } else if (std::abs(o.z()) > r) {
    return kInf;
  }
  if (t_start > t_end) return kInf;

  // Quartic in s = t - t_start, from (|p|² + R² - r²)² = 4 R² (p_x² + p_y²).
  const Eigen::Vector3d p = o + t_start * d;
  const double k = p.squaredNorm() + R * R - r * r;
  const double b = p.dot(d);
  const double R2 = R * R;
  const double a3 = 4.0 * b;
  const double a2 = 4.0 * b * b + 2.0 * k - 4.0 * R2 * (d.x() * d.x() + d.y() * d.y());
  const double a1 = 4.0 * b * k - 8.0 * R2 * (p.x() * d.x() + p.y() * d.y());
  const double a0 = k * k - 4.0 * R2 * (p.x() * p.x() + p.y() * p.y());
  const auto f = [&](double s) { return (((s + a3) * s + a2) * s + a1) * s + a0; };
  const double length = t_end - t_start;

  if (f(0.0) <= 0.0) return t_start;
  // Split [0, length] at the critical points; f is monotone between them.
  double crit[3];
  const int n = SolveCubic(0.75 * a3, 0.5 * a2, 0.25 * a1, crit);
  std::sort(crit, crit + n);
  double lo = 0.0;
  double f_lo = f(0.0);
  for (int i = 0; i <= n; ++i) {
    double hi = i < n ? crit[i] : length;
    if (hi <= lo) continue;
    hi = std::min(hi, length);
    const double f_hi = f(hi);
    if (f_hi <= 0.0) {
      // Bracketed root in [lo, hi]: Illinois false position.
      double a = lo, fa = f_lo, c = hi, fc = f_hi;
      int side = 0;
      double x = hi;
      for (int it = 0; it < 60; ++it) {
        x = (fa * c - fc * a) / (fa - fc);
        const double fx = f(x);
        if (fx > 0.0) {
          a = x;
          fa = fx;
          if (side == -1) fc *= 0.5;
          side = -1;
        } else {
          c = x;
          fc = fx;
          if (side == 1) fa *= 0.5;
          side = 1;
        }
        if (c - a < 1e-10 || fx == 0.0) break;
      }
      return t_start + c;
    }
    lo = hi;
    f_lo = f_hi;
    if (lo >= length) break;
  }
  return kInf;
}

struct RingBasis {
  Eigen::Vector3d u, v, axis;
};

RingBasis BasisOf(const RingObstacle& ring) {
  const double c = std::cos(ring.yaw);
  const double s = std::sin(ring.yaw);
  return {Eigen::Vector3d(-s, c, 0.0), Eigen::Vector3d::UnitZ(), Eigen::Vector3d(c, s, 0.0)};
}

// Half extents of a ring's xy footprint.
Eigen::Vector2d RingFootprint(const RingObstacle& ring) {
  const double outer = ring.radius + 0.5 * ring.thickness;
  const double half_t = 0.5 * ring.thickness;
  const double c = std::abs(std::cos(ring.yaw));
  const double s = std::abs(std::sin(ring.yaw));
  return {outer * s + half_t * c, outer * c + half_t * s};
}

}  // namespace

double IntersectRay(const CylinderObstacle& cyl, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                    double t_max) {
  double t_enter = 0.0;
  double t_exit = t_max;
  // Circle in xy.
  const Eigen::Vector2d oc = o.head<2>() - cyl.center_W;
  const double a = d.x() * d.x() + d.y() * d.y();
  const double c = oc.squaredNorm() - cyl.radius * cyl.radius;
  if (a < 1e-24) {
    if (c > 0.0) return kInf;
  } else {
    const double b = oc.x() * d.x() + oc.y() * d.y();
    const double disc = b * b - a * c;
    if (disc < 0.0) return kInf;
    const double sq = std::sqrt(disc);
    // Numerically stable pair of roots.
    const double qq = -(b + std::copysign(sq, b));
    double t0 = qq / a;
    double t1 = qq != 0.0 ? c / qq : t0;
    if (t0 > t1) std::swap(t0, t1);
    t_enter = std::max(t_enter, t0);
    t_exit = std::min(t_exit, t1);
  }
  // Slab in z.
  if (std::abs(d.z()) < 1e-12) {
    if (o.z() < cyl.z_min || o.z() > cyl.z_max) return kInf;
  } else {
    double tz0 = (cyl.z_min - o.z()) / d.z();
    double tz1 = (cyl.z_max - o.z()) / d.z();
    if (tz0 > tz1) std::swap(tz0, tz1);
    t_enter = std::max(t_enter, tz0);
    t_exit = std::min(t_exit, tz1);
  }
  return t_enter <= t_exit ? t_enter : kInf;
}

double IntersectRay(const RingObstacle& ring, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                    double t_max) {
  const RingBasis basis = BasisOf(ring);
  const Eigen::Vector3d rel = o - ring.center_W;
  const Eigen::Vector3d o_l(rel.dot(basis.u), rel.dot(basis.v), rel.dot(basis.axis));
  const Eigen::Vector3d d_l(d.dot(basis.u), d.dot(basis.v), d.dot(basis.axis));
  return IntersectTorusLocal(o_l, d_l, ring.radius, 0.5 * ring.thickness, t_max);
}

double IntersectGround(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_max) {
  if (o.z() <= 0.0) return 0.0;
  if (d.z() >= 0.0) return kInf;
  const double t = -o.z() / d.z();
  return t <= t_max ? t : kInf;
}

void RayCasterOptions::Validate(const std::string& origin) const {
  CheckInRange(cell_size, Range::NonNegative(), origin, "cell_size");
  CheckInRange(max_cells_per_axis, Range::Closed(1, 1 << 16), origin, "max_cells_per_axis");
}

RayCaster::RayCaster(const ObstacleSet& obstacles, const RayCasterOptions& options)
    : obstacles_(obstacles) {
  options.Validate();
  const std::size_t n_items = obstacles_.cylinders.size() + obstacles_.rings.size();
  ring_frames_.reserve(obstacles_.rings.size());
  for (const RingObstacle& ring : obstacles_.rings) {
    const RingBasis b = BasisOf(ring);
    ring_frames_.push_back({ring.center_W, b.u, b.v, b.axis});
  }
  if (n_items == 0) return;

  // Footprints (min, max) per item.
  std::vector<Eigen::Vector4d> boxes;  // x0, y0, x1, y1
  boxes.reserve(n_items);
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(kInf);
  Eigen::Vector2d hi = -lo;
  z_lo_ = kInf;
  z_hi_ = -kInf;
  for (const CylinderObstacle& c : obstacles_.cylinders) {
    boxes.emplace_back(c.center_W.x() - c.radius, c.center_W.y() - c.radius,
                       c.center_W.x() + c.radius, c.center_W.y() + c.radius);
    z_lo_ = std::min(z_lo_, c.z_min);
    z_hi_ = std::max(z_hi_, c.z_max);
  }
  for (const RingObstacle& r : obstacles_.rings) {
    const Eigen::Vector2d h = RingFootprint(r);
    boxes.emplace_back(r.center_W.x() - h.x(), r.center_W.y() - h.y(), r.center_W.x() + h.x(),
                       r.center_W.y() + h.y());
    const double outer = r.radius + 0.5 * r.thickness;
    z_lo_ = std::min(z_lo_, r.center_W.z() - outer);
    z_hi_ = std::max(z_hi_, r.center_W.z() + outer);
  }
  for (const auto& b : boxes) {
    lo = lo.cwiseMin(b.head<2>());
    hi = hi.cwiseMax(b.tail<2>());
  }
  // Pad so that footprints never touch the grid border exactly.
  lo.array() -= 1e-6;
  hi.array() += 1e-6;
  const Eigen::Vector2d extent = hi - lo;
  double cs = options.cell_size;
  if (cs <= 0.0) {
    cs = std::sqrt(extent.x() * extent.y() / static_cast<double>(n_items));
    cs = std::max(cs, 0.05);
  }
  cs = std::max(cs, extent.maxCoeff() / options.max_cells_per_axis);
  cell_size_ = cs;
  grid_origin_ = lo;
  nx_ = std::max(1, static_cast<int>(std::ceil(extent.x() / cs)));
  ny_ = std::max(1, static_cast<int>(std::ceil(extent.y() / cs)));

  const auto cell_range = [&](const Eigen::Vector4d& b, int& x0, int& y0, int& x1, int& y1) {
    x0 = std::clamp(static_cast<int>(std::floor((b[0] - lo.x()) / cs)), 0, nx_ - 1);
    y0 = std::clamp(static_cast<int>(std::floor((b[1] - lo.y()) / cs)), 0, ny_ - 1);
    x1 = std::clamp(static_cast<int>(std::floor((b[2] - lo.x()) / cs)), 0, nx_ - 1);
    y1 = std::clamp(static_cast<int>(std::floor((b[3] - lo.y()) / cs)), 0, ny_ - 1);
  };
  cell_start_.assign(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_) + 1, 0);
  for (const auto& b : boxes) {
    int x0, y0, x1, y1;
    cell_range(b, x0, y0, x1, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) ++cell_start_[static_cast<std::size_t>(y * nx_ + x) + 1];
  }
  for (std::size_t i = 1; i < cell_start_.size(); ++i) cell_start_[i] += cell_start_[i - 1];
  cell_items_.resize(cell_start_.back());
  std::vector<std::uint32_t> fill(cell_start_.begin(), cell_start_.end() - 1);
  for (std::size_t item = 0; item < boxes.size(); ++item) {
    int x0, y0, x1, y1;
    cell_range(boxes[item], x0, y0, x1, y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x)
        cell_items_[fill[static_cast<std::size_t>(y * nx_ + x)]++] = static_cast<std::uint32_t>(item);
  }
}

std::size_t RayCaster::MemoryBytes() const {
  return obstacles_.cylinders.capacity() * sizeof(CylinderObstacle) +
         obstacles_.rings.capacity() * sizeof(RingObstacle) +
         ring_frames_.capacity() * sizeof(RingFrame) +
         (cell_start_.capacity() + cell_items_.capacity()) * sizeof(std::uint32_t);
}

void RayCaster::TestItem(std::uint32_t item, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                         RayHit& best) const {
  const std::size_t n_cyl = obstacles_.cylinders.size();
  if (item < n_cyl) {
    const double t = IntersectRay(obstacles_.cylinders[item], o, d, best.distance);
    if (t < best.distance) best = {t, {ObstacleKind::kCylinder, static_cast<int>(item)}};
    return;
  }
  const std::size_t k = item - n_cyl;
  const RingFrame& fr = ring_frames_[k];
  const RingObstacle& ring = obstacles_.rings[k];
  const Eigen::Vector3d rel = o - fr.center_W;
  const Eigen::Vector3d o_l(rel.dot(fr.u_W), rel.dot(fr.v_W), rel.dot(fr.axis_W));
  const Eigen::Vector3d d_l(d.dot(fr.u_W), d.dot(fr.v_W), d.dot(fr.axis_W));
  const double t = IntersectTorusLocal(o_l, d_l, ring.radius, 0.5 * ring.thickness, best.distance);
  if (t < best.distance) best = {t, {ObstacleKind::kRing, static_cast<int>(k)}};
}

RayHit RayCaster::Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_range) const {
  RayHit best;
  best.distance = max_range;  // used as the search bound; reset to +inf if nothing is hit
  bool any = false;
  if (obstacles_.ground) {
    const double t = IntersectGround(o, d, max_range);
    if (t <= max_range) {
      best = {t, {ObstacleKind::kGround, 0}};
      any = true;
    }
  }
  const auto finish = [&]() { return any ? best : RayHit{}; };
  if (nx_ == 0) return finish();

  // Clip the ray to the obstacles' z range and the grid's xy box.
  double t0 = 0.0;
  double t1 = best.distance;
  const auto clip = [&](double oo, double dd, double lo, double hi) {
    if (std::abs(dd) < 1e-15) {
      if (oo < lo || oo > hi) t1 = -1.0;
      return;
    }
    double a = (lo - oo) / dd;
    double b = (hi - oo) / dd;
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  };
  clip(o.z(), d.z(), z_lo_, z_hi_);
  clip(o.x(), d.x(), grid_origin_.x(), grid_origin_.x() + nx_ * cell_size_);
  clip(o.y(), d.y(), grid_origin_.y(), grid_origin_.y() + ny_ * cell_size_);
  if (t0 > t1) return finish();

  // Amanatides–Woo walk from the entry point.
  const Eigen::Vector3d p = o + t0 * d;
  int ix = std::clamp(static_cast<int>(std::floor((p.x() - grid_origin_.x()) / cell_size_)), 0, nx_ - 1);
  int iy = std::clamp(static_cast<int>(std::floor((p.y() - grid_origin_.y()) / cell_size_)), 0, ny_ - 1);
  const int step_x = d.x() > 0.0 ? 1 : -1;
  const int step_y = d.y() > 0.0 ? 1 : -1;
  const double delta_x = d.x() != 0.0 ? cell_size_ / std::abs(d.x()) : kInf;
  const double delta_y = d.y() != 0.0 ? cell_size_ / std::abs(d.y()) : kInf;
  double next_x = d.x() != 0.0
                      ? (grid_origin_.x() + (ix + (step_x > 0 ? 1 : 0)) * cell_size_ - o.x()) / d.x()
                      : kInf;
  double next_y = d.y() != 0.0
                      ? (grid_origin_.y() + (iy + (step_y > 0 ? 1 : 0)) * cell_size_ - o.y()) / d.y()
                      : kInf;
  const double start_distance = best.distance;
  for (;;) {
    const std::size_t cell = static_cast<std::size_t>(iy * nx_ + ix);
    for (std::uint32_t k = cell_start_[cell]; k < cell_start_[cell + 1]; ++k) {
      TestItem(cell_items_[k], o, d, best);
    }
    const double cell_exit = std::min(next_x, next_y);
    if (best.distance <= cell_exit || cell_exit > t1) break;
    if (next_x < next_y) {
      ix += step_x;
      if (ix < 0 || ix >= nx_) break;
      next_x += delta_x;
    } else {
      iy += step_y;
      if (iy < 0 || iy >= ny_) break;
      next_y += delta_y;
    }
  }
  if (best.distance < start_distance) any = true;
  if (!any) return RayHit{};
  return best;
}

}  // namespace quadtune::physics
