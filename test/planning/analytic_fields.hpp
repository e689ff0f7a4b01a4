#pragma once
/// \file
/// Analytic DistanceFields for the trajectory tests and benchmarks: the cylinders of an
/// ObstacleSet (same signed distance as physics::SignedDistance, with its exact gradient), and an
/// affine half-space field whose Hessian is zero (for exact Hessian checks).

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "quadtune/physics/obstacles.hpp"
#include "quadtune/planning/distance_field.hpp"
#include "quadtune/planning/esdf.hpp"

namespace quadtune::planning::testing {

/// Signed distance to one cylinder (same as physics::SignedDistance), value only.
inline double CylinderDistanceValue(const physics::CylinderObstacle& c,
                                    const Eigen::Vector3d& p_W) {
  const double dx = p_W.x() - c.center_W.x();
  const double dy = p_W.y() - c.center_W.y();
  const double radial = std::sqrt(dx * dx + dy * dy) - c.radius;
  const double axial = std::abs(p_W.z() - 0.5 * (c.z_min + c.z_max)) - 0.5 * (c.z_max - c.z_min);
  if (radial > 0.0 && axial > 0.0) return std::sqrt(radial * radial + axial * axial);
  return radial >= axial ? radial : axial;
}

/// Signed distance to one cylinder (same value as CylinderDistanceValue) with its exact gradient
/// and Hessian (the Hessian of the branch in use; zero on the flat faces).
inline double CylinderDistance(const physics::CylinderObstacle& c, const Eigen::Vector3d& p_W,
                               Eigen::Vector3d* grad_W, Eigen::Matrix3d* hess_W) {
  const double dx = p_W.x() - c.center_W.x();
  const double dy = p_W.y() - c.center_W.y();
  const double rho = std::sqrt(dx * dx + dy * dy);
  const Eigen::Vector2d u =
      rho > 1e-12 ? Eigen::Vector2d(dx / rho, dy / rho) : Eigen::Vector2d(1, 0);
  const double radial = rho - c.radius;
  const double z_mid = 0.5 * (c.z_min + c.z_max);
  const double sz = p_W.z() >= z_mid ? 1.0 : -1.0;
  const double axial = std::abs(p_W.z() - z_mid) - 0.5 * (c.z_max - c.z_min);
  // ∇radial = (u, 0), ∇²radial = (I₂ − u uᵀ)/ρ in xy; ∇axial = (0, 0, sz), ∇²axial = 0.
  Eigen::Matrix3d hess_radial = Eigen::Matrix3d::Zero();
  if (hess_W != nullptr && rho > 1e-12) {
    hess_radial.topLeftCorner<2, 2>() = (Eigen::Matrix2d::Identity() - u * u.transpose()) / rho;
  }
  const Eigen::Vector3d g_radial(u.x(), u.y(), 0.0);
  const Eigen::Vector3d g_axial(0.0, 0.0, sz);
  double d = 0.0;
  Eigen::Vector3d g;
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  if (radial > 0.0 && axial > 0.0) {
    d = std::sqrt(radial * radial + axial * axial);
    const Eigen::Vector2d n(radial / d, axial / d);
    Eigen::Matrix<double, 2, 3> jac;
    jac.row(0) = g_radial.transpose();
    jac.row(1) = g_axial.transpose();
    g = jac.transpose() * n;
    if (hess_W != nullptr) {
      h = jac.transpose() * ((Eigen::Matrix2d::Identity() - n * n.transpose()) / d) * jac +
          n.x() * hess_radial;
    }
  } else if (radial >= axial) {
    d = radial;
    g = g_radial;
    h = hess_radial;
  } else {
    d = axial;
    g = g_axial;
  }
  if (grad_W != nullptr) *grad_W = g;
  if (hess_W != nullptr) *hess_W = h;
  return d;
}

/// Signed distance to the cylinders of an ObstacleSet (rings and ground ignored). Thread-safe.
///
/// Evaluate() is the exact nearest-cylinder distance (as physics::SignedDistance).
/// EvaluateWithHessian() is its C² soft-min  d_s = −h·log Σ_i exp(−d_i/h)  (h: smoothing length)
/// with exact gradient Σ w_i ∇d_i and Hessian Σ w_i ∇²d_i − (1/h)(Σ w_i ∇d_i ∇d_iᵀ − ∇d_s ∇d_sᵀ),
/// w_i = exp(−(d_i − d_s)/h). It never exceeds the exact distance and under-estimates it by at
/// most h·log(k) where k cylinders are about equally near (≈ 0.7 h on the ridge between two), the
/// role a tricubic interpolant plays for an ESDF (smoothing at the voxel scale). The default
/// h = 0.025 m (a quarter of the 0.1 m map voxel) was chosen on the forest benchmark: h = 0.01 to
/// 0.05 m need about the same Newton iterations, larger h (0.1, 0.2 m) under-estimates distances
/// in a dense forest enough to raise the cost and cause collisions. Cylinders with
/// d_i − min_j d_j > 40 h (relative weight < 5e-18, below double rounding of Σ w_i ≥ 1) are
/// left out of the sums.
class CylinderField final : public DistanceField {
 public:
  explicit CylinderField(std::vector<physics::CylinderObstacle> cylinders, double smoothing = 0.025)
      : cylinders_(std::move(cylinders)), smoothing_(smoothing) {}

  double Evaluate(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W) const override {
    double best = std::numeric_limits<double>::infinity();
    std::size_t best_k = 0;
    for (std::size_t k = 0; k < cylinders_.size(); ++k) {
      const double d = CylinderDistanceValue(cylinders_[k], p_W);
      if (d < best) {
        best = d;
        best_k = k;
      }
    }
    if (grad_W != nullptr) {
      grad_W->setZero();
      if (!cylinders_.empty()) CylinderDistance(cylinders_[best_k], p_W, grad_W, nullptr);
    }
    return best;
  }

  double EvaluateWithHessian(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W,
                             Eigen::Matrix3d* hess_W) const override {
    if (cylinders_.empty()) {
      if (hess_W != nullptr) hess_W->setZero();
      return Evaluate(p_W, grad_W);
    }
    // Pass 1: all distances (value only) and their minimum; pass 2: weights and derivatives of
    // the cylinders that matter.
    thread_local std::vector<double> distances;
    distances.resize(cylinders_.size());
    double d_min = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < cylinders_.size(); ++k) {
      distances[k] = CylinderDistanceValue(cylinders_[k], p_W);
      d_min = std::min(d_min, distances[k]);
    }
    const double inv_h = 1.0 / smoothing_;
    const double cutoff = d_min + 40.0 * smoothing_;
    double sum_w = 0.0;
    Eigen::Vector3d sum_g = Eigen::Vector3d::Zero();
    Eigen::Matrix3d sum_h = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d sum_gg = Eigen::Matrix3d::Zero();
    const bool want_grad = grad_W != nullptr || hess_W != nullptr;
    for (std::size_t k = 0; k < cylinders_.size(); ++k) {
      if (distances[k] > cutoff) continue;
      const double w = std::exp(-(distances[k] - d_min) * inv_h);
      sum_w += w;
      if (!want_grad) continue;
      Eigen::Vector3d g;
      Eigen::Matrix3d h;
      CylinderDistance(cylinders_[k], p_W, &g, hess_W != nullptr ? &h : nullptr);
      sum_g += w * g;
      if (hess_W != nullptr) {
        sum_h += w * h;
        sum_gg += w * g * g.transpose();
      }
    }
    const double d_s = d_min - smoothing_ * std::log(sum_w);
    const Eigen::Vector3d g_s = sum_g / sum_w;
    if (grad_W != nullptr) *grad_W = g_s;
    if (hess_W != nullptr) {
      *hess_W = sum_h / sum_w - inv_h * (sum_gg / sum_w - g_s * g_s.transpose());
    }
    return d_s;
  }

  [[nodiscard]] bool ProvidesCurvature() const override { return true; }

  /// Smoothing length h (m) of EvaluateWithHessian().
  [[nodiscard]] double Smoothing() const { return smoothing_; }

 private:
  std::vector<physics::CylinderObstacle> cylinders_;
  double smoothing_;
};

/// d(p) = n·p − offset (n unit): an affine field, zero Hessian. Thread-safe.
class HalfSpaceField final : public DistanceField {
 public:
  HalfSpaceField(const Eigen::Vector3d& normal, double offset)
      : normal_(normal.normalized()), offset_(offset) {}
  double Evaluate(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W) const override {
    if (grad_W != nullptr) *grad_W = normal_;
    return normal_.dot(p_W) - offset_;
  }

 private:
  Eigen::Vector3d normal_;
  double offset_;
};

/// No obstacles: a large constant distance. Thread-safe.
class EmptyField final : public DistanceField {
 public:
  double Evaluate(const Eigen::Vector3d& /*p_W*/, Eigen::Vector3d* grad_W) const override {
    if (grad_W != nullptr) grad_W->setZero();
    return 100.0;
  }
};

/// Esdf (0.1 m voxels by default) of the cylinders, voxelised by cell centres inside a cylinder,
/// over x ∈ [x0, x1], y ∈ [y0, y1], z ∈ [z0, z1].
inline Esdf VoxelisedCylinders(const std::vector<physics::CylinderObstacle>& cylinders, double x0,
                               double x1, double y0, double y1, double z0, double z1,
                               double res = 0.1) {
  const Eigen::Vector3d origin(x0, y0, z0);
  const Eigen::Vector3i dims(static_cast<int>(std::ceil((x1 - x0) / res)),
                             static_cast<int>(std::ceil((y1 - y0) / res)),
                             static_cast<int>(std::ceil((z1 - z0) / res)));
  std::vector<std::uint8_t> occupancy(static_cast<std::size_t>(dims.prod()), 0);
  for (int z = 0; z < dims.z(); ++z)
    for (int y = 0; y < dims.y(); ++y)
      for (int x = 0; x < dims.x(); ++x) {
        const Eigen::Vector3d c =
            origin + (Eigen::Vector3d(x, y, z) + Eigen::Vector3d::Constant(0.5)) * res;
        for (const auto& cyl : cylinders) {
          if (CylinderDistanceValue(cyl, c) <= 0.0) {
            occupancy[static_cast<std::size_t>(x + dims.x() * (y + dims.y() * z))] = 1;
            break;
          }
        }
      }
  return Esdf::FromOccupancy(origin, res, dims, occupancy);
}

/// A forest of cylinders (radius 0.1–0.25 m, height 0–3 m) on a jittered grid (±20 %) with the
/// given spacing (m) over x ∈ [x0, x1], y ∈ [y0, y1], keeping a disc of `free_radius` around each
/// of `keep_free` points clear. Deterministic for a seed.
inline std::vector<physics::CylinderObstacle> MakeForest(
    double spacing, double x0, double x1, double y0, double y1,
    const std::vector<Eigen::Vector2d>& keep_free, double free_radius, unsigned seed) {
  std::vector<physics::CylinderObstacle> cylinders;
  unsigned state = seed * 2654435761u + 12345u;
  auto uniform = [&state] {
    state = state * 1664525u + 1013904223u;
    return static_cast<double>(state >> 8) / static_cast<double>(1u << 24);
  };
  for (double x = x0; x <= x1 + 1e-9; x += spacing) {
    for (double y = y0; y <= y1 + 1e-9; y += spacing) {
      physics::CylinderObstacle c;
      c.center_W = Eigen::Vector2d(x + (uniform() - 0.5) * 0.4 * spacing,
                                   y + (uniform() - 0.5) * 0.4 * spacing);
      c.radius = 0.1 + 0.15 * uniform();
      c.z_min = 0.0;
      c.z_max = 3.0;
      bool blocked = false;
      for (const auto& p : keep_free) {
        if ((c.center_W - p).norm() < free_radius + c.radius) blocked = true;
      }
      if (!blocked) cylinders.push_back(c);
    }
  }
  return cylinders;
}

}  // namespace quadtune::planning::testing
