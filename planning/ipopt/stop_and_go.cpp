#include "quadtune/planning/ipopt/stop_and_go.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "quadtune/common/error.hpp"
#include "quadtune/planning/quintic.hpp"

namespace quadtune::planning {

PlanResult StopAndGoAlongPath(const TrajectoryOptimizer& optimizer, const PlanningQuery& query,
                              const PlannerParams& params, double speed) {
  QT_DEMAND(speed > 0.0 && std::isfinite(speed), "stop-and-go speed must be positive");
  const double v_peak = std::min(speed, params.v_des);
  const std::vector<Eigen::Vector3d>& path = query.initial_path_W;
  std::vector<double> durations;
  std::vector<Trajectory::Coefficients> pieces;
  Eigen::Vector3d p = query.p0_W;
  Eigen::Vector3d v = query.v0_W;
  Eigen::Vector3d a = query.a0_W;
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  for (std::size_t i = 1; i < path.size(); ++i) {
    const double length = (path[i] - p).norm();
    if (length < 1e-6) continue;
    const double T = std::max(
        {1.875 * length / v_peak, std::sqrt(10.0 / std::sqrt(3.0) * length / params.a_max), 0.1});
    pieces.push_back(QuinticBoundaryValue(p, v, a, path[i], zero, zero, T));
    durations.push_back(T);
    p = path[i];
    v = zero;
    a = zero;
  }
  PlanResult result;
  if (pieces.empty()) {
    result.status = PlanStatus::kInvalidInput;
    result.message = "stop-and-go: the front end's path has no length";
    return result;
  }
  result.trajectory = Trajectory(std::move(durations), std::move(pieces));
  result.cost.jerk = result.trajectory.JerkEnergy();
  optimizer.Check(query.p0_W, query.field, params, &result);
  return result;
}

}  // namespace quadtune::planning
