#pragma once
/// \file
/// The closed loop's plug-in point for trajectory back ends: what turns a recorded planning query
/// (start state, local goal, front-end path, map snapshot) into a trajectory. The replanning FSM
/// and the closed-loop flight (sim::Replanner, sim::Fly) and the engine's planner plug-ins take
/// any TrajectoryBackend; the project ships two:
///
/// - IpoptBackend (ipopt/ipopt_backend.hpp): the minimum-jerk Ipopt optimiser on the query's
///   distance-field snapshot (SolveQuery, with its retries), and the stop-and-go fallback
///   (StopAndGoAlongPath, ipopt/stop_and_go.hpp, on quintic.hpp's StopAndGo);
/// - EgoBackend (ego/ego_optimizer.hpp): EGO-Planner's B-spline optimiser on the query's
///   occupancy snapshot, solved by L-BFGS; with EgoOptions::stop_and_go, the same stop-and-go
///   fallback (quintic.hpp's StopAndGo) judged by its own check.
///
/// This header and the rest of the planning core name no back end's types: the back ends live in
/// their own folders beside the core and include it, never the other way round.
///
/// A back end states which map snapshot its queries need (QuerySnapshot); LocalPlanner::MakeQuery
/// records that one, so a recorded query holds everything a later re-solve reads.
///
/// Thread safety: a back end is immutable after construction; Solve() and Fallback() may run
/// concurrently from many threads on shared queries.

#include <optional>
#include <string>

#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/plan_result.hpp"

namespace quadtune::planning {

/// A trajectory back end (see the file comment).
class TrajectoryBackend {
 public:
  virtual ~TrajectoryBackend() = default;
  /// Short name ("ipopt", "ego").
  [[nodiscard]] virtual std::string Name() const = 0;
  /// The map snapshot that MakeQuery must record for this back end.
  [[nodiscard]] virtual QuerySnapshot Snapshot() const = 0;
  /// Plans a trajectory for `query` with parameters `params` (θ_s and the rest, as in force);
  /// `options` are the planning-step settings of the flight. The outcome's trajectory starts at
  /// query.p0_W at time 0. Never throws for planning failures (they are the outcome's status).
  [[nodiscard]] virtual PlanOutcome Solve(const PlanningQuery& query, const PlannerParams& params,
                                          const LocalPlannerOptions& options) const = 0;
  /// A slow trajectory along the front-end path for a start (nearly) at rest after every attempt
  /// of Solve() failed, judged by the back end's own acceptance check (its status says whether
  /// it may be flown), with peak speed `speed` (m/s, > 0); nullopt when the back end has none.
  [[nodiscard]] virtual std::optional<PlanResult> Fallback(const PlanningQuery& query,
                                                           const PlannerParams& params,
                                                           double speed) const = 0;
};

}  // namespace quadtune::planning
