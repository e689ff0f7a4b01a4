#pragma once
/// \file
/// Trajectories built from quintic pieces without optimisation: the piece matching position,
/// velocity and acceleration at both ends, a smooth emergency stop, and the front end's path flown
/// stop-and-go (the fallback of the Ipopt back end, IpoptBackend::Fallback, and of the
/// replanning FSM in quadtune::sim).
///
/// Thread safety: pure functions of their arguments; StopAndGoAlongPath reads `optimizer` only
/// through its const members.

#include <Eigen/Core>

#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/trajectory.hpp"
#include "quadtune/planning/trajectory_optimizer.hpp"

namespace quadtune::planning {

/// A quintic from (p0, v0, a0) to rest at a point chosen so that the average deceleration is
/// `decel` (m/s², > 0): duration T = max(2|v0|/decel, 0.2 s). Used for emergency braking.
[[nodiscard]] Trajectory BrakingTrajectory(const Eigen::Vector3d& p0, const Eigen::Vector3d& v0,
                                           const Eigen::Vector3d& a0, double decel);

/// The front end's path of `query` flown stop-and-go: one quintic per straight segment of
/// query.initial_path_W, from (p0, v0, a0) for the first and from rest for the others, to rest at
/// the segment's end, each as slow as the peak speed `speed` (m/s, > 0) and a_max require
/// (a rest-to-rest quintic over L peaks at 1.875 L/T and 5.77 L/T²). From rest every piece stays
/// on its segment, and the segments are free in the inflated map, so the path can be flown even
/// where the back end's optimum is not: a passage that the collision penalty cannot centre the
/// trajectory in. The result carries optimizer.Check's verdict and the trajectory's ∫|jerk|² dt
/// (cost.jerk, Trajectory::JerkEnergy); iterations and evaluations are 0.
[[nodiscard]] PlanResult StopAndGoAlongPath(const TrajectoryOptimizer& optimizer,
                                            const PlanningQuery& query, const PlannerParams& params,
                                            double speed);

/// The quintic of duration T (s) matching position, velocity and acceleration at both ends.
[[nodiscard]] Trajectory::Coefficients QuinticBoundaryValue(
    const Eigen::Vector3d& p0, const Eigen::Vector3d& v0, const Eigen::Vector3d& a0,
    const Eigen::Vector3d& p1, const Eigen::Vector3d& v1, const Eigen::Vector3d& a1, double T);

}  // namespace quadtune::planning
