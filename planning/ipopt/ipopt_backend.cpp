#include "quadtune/planning/ipopt/ipopt_backend.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

#include "quadtune/common/error.hpp"
#include "quadtune/planning/ipopt/stop_and_go.hpp"

namespace quadtune::planning {

PlanRequest ToRequest(const PlanningQuery& query, bool use_warm_start) {
  PlanRequest r;
  r.p0_W = query.p0_W;
  r.v0_W = query.v0_W;
  r.a0_W = query.a0_W;
  r.goal_W = query.goal_W;
  r.goal_v_W = query.goal_v_W;
  r.initial_path_W = query.initial_path_W;
  r.braking_deceleration = query.braking_deceleration;
  if (use_warm_start && query.previous.has_value() && !query.previous->Empty()) {
    r.warm_start = &*query.previous;
    r.warm_start_time = query.previous_time;
  }
  return r;
}

PlanOutcome SolveQuery(const TrajectoryOptimizer& optimizer, const PlanningQuery& query,
                       const PlannerParams& params, const LocalPlannerOptions& options) {
  PlanOutcome out;
  const int attempts = std::max(1, params.max_attempts);
  // The parameters are checked once here; invalid ones take Solve()'s path, which reports them.
  bool valid = true;
  try {
    params.Validate();
  } catch (const ConfigError&) {
    valid = false;
  }
  PlannerParams attempt_params = params;
  for (int k = 0; k < attempts; ++k) {
    PlanRequest request = ToRequest(query, /*use_warm_start=*/k == 0);
    if (k >= 2) request.speed_scale = std::pow(options.retry_slowdown, k - 1);
    PlanResult r = valid ? optimizer.SolveValidated(request, query.field, attempt_params)
                         : optimizer.Solve(request, query.field, attempt_params);
    if (r.status == PlanStatus::kCollision) attempt_params.w_col *= options.retry_collision_gain;
    out.attempts = k + 1;
    out.solve_time_s += r.solve_time_s;
    out.compute_units += r.compute_units;
    const bool ok = r.Ok();
    out.result = std::move(r);
    if (ok) {
      out.failed_attempts = k;
      return out;
    }
    out.failed_attempts = k + 1;
  }
  return out;
}

PlanOutcome IpoptBackend::Solve(const PlanningQuery& query, const PlannerParams& params,
                                const LocalPlannerOptions& options) const {
  return SolveQuery(optimizer_, query, params, options);
}

std::optional<PlanResult> IpoptBackend::Fallback(const PlanningQuery& query,
                                                 const PlannerParams& params,
                                                 double speed) const {
  return StopAndGoAlongPath(optimizer_, query, params, speed);
}

}  // namespace quadtune::planning
