#include "quadtune/planning/quintic.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "quadtune/common/error.hpp"

namespace quadtune::planning {

Trajectory::Coefficients QuinticBoundaryValue(const Eigen::Vector3d& p0, const Eigen::Vector3d& v0,
                                              const Eigen::Vector3d& a0, const Eigen::Vector3d& p1,
                                              const Eigen::Vector3d& v1, const Eigen::Vector3d& a1,
                                              double T) {
  QT_DEMAND(T > 0.0 && std::isfinite(T), "quintic duration must be positive");
  Trajectory::Coefficients c;
  c.col(0) = p0;
  c.col(1) = v0;
  c.col(2) = 0.5 * a0;
  // End conditions for the three highest coefficients (rows: position, velocity, acceleration).
  Eigen::Matrix3d m;
  const double T2 = T * T, T3 = T2 * T, T4 = T3 * T, T5 = T4 * T;
  m << T3, T4, T5, 3 * T2, 4 * T3, 5 * T4, 6 * T, 12 * T2, 20 * T3;
  const Eigen::Matrix3d m_inv = m.inverse();
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Vector3d rhs(p1[axis] - p0[axis] - v0[axis] * T - 0.5 * a0[axis] * T2,
                              v1[axis] - v0[axis] - a0[axis] * T, a1[axis] - a0[axis]);
    const Eigen::Vector3d high = m_inv * rhs;
    c(axis, 3) = high[0];
    c(axis, 4) = high[1];
    c(axis, 5) = high[2];
  }
  return c;
}

Trajectory BrakingTrajectory(const Eigen::Vector3d& p0, const Eigen::Vector3d& v0,
                             const Eigen::Vector3d& a0, double decel) {
  QT_DEMAND(decel > 0.0, "braking deceleration must be positive");
  const double T = std::max(2.0 * v0.norm() / decel, 0.2);
  // Stopping point of a smooth stop: the distance covered at the mean speed |v0|/2, plus the
  // contribution of the initial acceleration.
  const Eigen::Vector3d p1 = p0 + 0.5 * v0 * T + a0 * T * T / 12.0;
  return Trajectory({T}, {QuinticBoundaryValue(p0, v0, a0, p1, Eigen::Vector3d::Zero(),
                                               Eigen::Vector3d::Zero(), T)});
}

std::optional<Trajectory> StopAndGo(const std::vector<Eigen::Vector3d>& path,
                                    const Eigen::Vector3d& p0, const Eigen::Vector3d& v0,
                                    const Eigen::Vector3d& a0, double v_peak, double a_max) {
  QT_DEMAND(v_peak > 0.0 && std::isfinite(v_peak), "stop-and-go speed must be positive");
  QT_DEMAND(a_max > 0.0 && std::isfinite(a_max), "stop-and-go a_max must be positive");
  std::vector<double> durations;
  std::vector<Trajectory::Coefficients> pieces;
  Eigen::Vector3d p = p0;
  Eigen::Vector3d v = v0;
  Eigen::Vector3d a = a0;
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  for (std::size_t i = 1; i < path.size(); ++i) {
    const double length = (path[i] - p).norm();
    if (length < 1e-6) continue;
    const double T =
        std::max({1.875 * length / v_peak, std::sqrt(10.0 / std::sqrt(3.0) * length / a_max), 0.1});
    pieces.push_back(QuinticBoundaryValue(p, v, a, path[i], zero, zero, T));
    durations.push_back(T);
    p = path[i];
    v = zero;
    a = zero;
  }
  if (pieces.empty()) return std::nullopt;
  return Trajectory(std::move(durations), std::move(pieces));
}

}  // namespace quadtune::planning
