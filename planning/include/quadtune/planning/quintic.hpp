#pragma once
/// \file
/// Quintic pieces made without optimisation: the piece matching position, velocity and
/// acceleration at both ends, and a smooth emergency stop (the replanning FSM's, quadtune::sim;
/// the Ipopt back end's stop-and-go fallback builds on the first).
///
/// Thread safety: pure functions of their arguments.

#include <Eigen/Core>

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

}  // namespace quadtune::planning
