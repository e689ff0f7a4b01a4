#include "quadtune/planning/ipopt/stop_and_go.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "quadtune/common/error.hpp"
#include "quadtune/planning/quintic.hpp"

namespace quadtune::planning {

PlanResult StopAndGoAlongPath(const TrajectoryOptimizer& optimizer, const PlanningQuery& query,
                              const PlannerParams& params, double speed) {
  QT_DEMAND(speed > 0.0 && std::isfinite(speed), "stop-and-go speed must be positive");
  std::optional<Trajectory> trajectory =
      StopAndGo(query.initial_path_W, query.p0_W, query.v0_W, query.a0_W,
                std::min(speed, params.v_des), params.a_max);
  PlanResult result;
  if (!trajectory) {
    result.status = PlanStatus::kInvalidInput;
    result.message = "stop-and-go: the front end's path has no length";
    return result;
  }
  result.trajectory = std::move(*trajectory);
  result.cost.jerk = result.trajectory.JerkEnergy();
  optimizer.Check(query.p0_W, query.field, params, &result);
  return result;
}

}  // namespace quadtune::planning
