#include "quadtune/planning/trajectory_backend.hpp"

#include "quadtune/planning/stop_and_go.hpp"

namespace quadtune::planning {

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
