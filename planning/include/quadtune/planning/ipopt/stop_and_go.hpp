#pragma once
/// \file
/// The front end's path flown stop-and-go, one quintic per segment (quintic.hpp): the fallback of
/// the Ipopt back end (IpoptBackend::Fallback, ipopt_backend.hpp), judged by its optimiser's
/// acceptance check.
///
/// Thread safety: a pure function of its arguments; StopAndGoAlongPath reads `optimizer` only
/// through its const members.

#include "quadtune/planning/ipopt/trajectory_optimizer.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/plan_result.hpp"

namespace quadtune::planning {

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

}  // namespace quadtune::planning
