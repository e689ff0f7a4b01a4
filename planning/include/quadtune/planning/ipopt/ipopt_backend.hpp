#pragma once
/// \file
/// The Ipopt minimum-jerk back end of the closed loop (trajectory_backend.hpp): a recorded query
/// solved by TrajectoryOptimizer on its distance-field snapshot, retried as SolveQuery says, with
/// the stop-and-go fallback (stop_and_go.hpp).
///
/// Thread safety: IpoptBackend is immutable; Solve() and Fallback() may run concurrently from
/// many threads (TrajectoryOptimizer::Solve may); ToRequest and SolveQuery are pure functions of
/// their arguments.

#include <optional>
#include <string>

#include "quadtune/planning/ipopt/trajectory_optimizer.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/plan_result.hpp"
#include "quadtune/planning/trajectory_backend.hpp"

namespace quadtune::planning {

/// The optimiser request for `query` (warm start optional; it points into `query`).
[[nodiscard]] PlanRequest ToRequest(const PlanningQuery& query, bool use_warm_start = true);

/// Solves a recorded query with short-term parameters θ_s (the rest of `params` is used as
/// given). Attempt 0 warm-starts from the previous trajectory when there is one; attempt 1 starts
/// cold; attempt k ≥ 2 also slows the allocation (PlanRequest::speed_scale =
/// options.retry_slowdown^(k−1), the limits stay v_des and a_max); after an attempt that failed
/// the clearance check, the next ones weight the collision cost options.retry_collision_gain
/// times more (cumulatively). Only those two fields of `options` are read. Stops at the first
/// success or after params.max_attempts. Never throws for solver failures.
///
/// Thread safety: safe to call concurrently (TrajectoryOptimizer::Solve is).
[[nodiscard]] PlanOutcome SolveQuery(const TrajectoryOptimizer& optimizer,
                                     const PlanningQuery& query, const PlannerParams& params,
                                     const LocalPlannerOptions& options = {});

/// The Ipopt minimum-jerk back end: Solve() is SolveQuery(optimizer, ...), Fallback() is
/// StopAndGoAlongPath(optimizer, ...). Holds a reference: `optimizer` must outlive it.
class IpoptBackend final : public TrajectoryBackend {
 public:
  explicit IpoptBackend(const TrajectoryOptimizer& optimizer) : optimizer_(optimizer) {}

  [[nodiscard]] std::string Name() const override { return "ipopt"; }
  [[nodiscard]] QuerySnapshot Snapshot() const override { return QuerySnapshot::kDistanceField; }
  [[nodiscard]] PlanOutcome Solve(const PlanningQuery& query, const PlannerParams& params,
                                  const LocalPlannerOptions& options) const override;
  [[nodiscard]] std::optional<PlanResult> Fallback(const PlanningQuery& query,
                                                   const PlannerParams& params,
                                                   double speed) const override;
  [[nodiscard]] const TrajectoryOptimizer& optimizer() const { return optimizer_; }

 private:
  const TrajectoryOptimizer& optimizer_;
};

}  // namespace quadtune::planning
