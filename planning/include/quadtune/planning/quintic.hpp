#pragma once
/// \file
/// Quintic pieces made without optimisation: the piece matching position, velocity and
/// acceleration at both ends, a smooth emergency stop (the replanning FSM's, quadtune::sim), and
/// a path flown stop-and-go (the fallback of both back ends, each judging it by its own check).
///
/// Thread safety: pure functions of their arguments.

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "quadtune/planning/trajectory.hpp"

namespace quadtune::planning {

/// A quintic from (p0, v0, a0) to rest at a point chosen so that the average deceleration is
/// `decel` (m/s², > 0): duration T = max(2|v0|/decel, 0.2 s). Used for emergency braking.
[[nodiscard]] Trajectory BrakingTrajectory(const Eigen::Vector3d& p0, const Eigen::Vector3d& v0,
                                           const Eigen::Vector3d& a0, double decel);

/// The quintic of duration T (s) matching position, velocity and acceleration at both ends.
[[nodiscard]] Trajectory::Coefficients QuinticBoundaryValue(
    const Eigen::Vector3d& p0, const Eigen::Vector3d& v0, const Eigen::Vector3d& a0,
    const Eigen::Vector3d& p1, const Eigen::Vector3d& v1, const Eigen::Vector3d& a1, double T);

/// The polyline `path` flown stop-and-go: one quintic per straight segment, from (p0, v0, a0) for
/// the first and from rest for the others, to rest at the segment's end, each as slow as the
/// peak speed `v_peak` (m/s, > 0) and `a_max` (m/s², > 0) require (a rest-to-rest quintic over L
/// peaks at 1.875 L/T and 5.77 L/T²), at least 0.1 s. From rest every piece stays on its segment.
/// path[0] stands for p0 (its first point is skipped when p0 is on it); nullopt when the path has
/// no length.
[[nodiscard]] std::optional<Trajectory> StopAndGo(const std::vector<Eigen::Vector3d>& path,
                                                  const Eigen::Vector3d& p0,
                                                  const Eigen::Vector3d& v0,
                                                  const Eigen::Vector3d& a0, double v_peak,
                                                  double a_max);

}  // namespace quadtune::planning
