#include "quadtune/planning/local_planner.hpp"

#include <algorithm>
#include <cmath>

#include "quadtune/common/error.hpp"

namespace quadtune::planning {

std::size_t PlanningQuery::MemoryBytes() const {
  std::size_t bytes = sizeof(PlanningQuery) + field.MemoryBytes() - sizeof(Esdf);
  bytes += initial_path_W.capacity() * sizeof(Eigen::Vector3d);
  if (occupancy) bytes += occupancy->MemoryBytes() + sizeof(LocalMap);
  if (previous)
    bytes += previous->Durations().size() * (sizeof(double) + sizeof(Trajectory::Coefficients));
  return bytes;
}

void LocalPlannerOptions::Validate(const std::string& origin) const {
  search.Validate(origin);
  esdf.Validate(origin);
  CheckInRange(field_margin, Range::NonNegative(), origin, "field_margin");
  CheckInRange(retry_slowdown, {0.0, 1.0, true, false}, origin, "retry_slowdown");
  CheckInRange(retry_collision_gain, Range::Closed(1.0, 1e6), origin, "retry_collision_gain");
}

void LocalPlannerOptions::CheckParams(const PlannerParams& params,
                                      const std::string& origin) const {
  if (!(params.clearance < esdf.max_distance)) {
    throw ConfigError(origin, "clearance",
                      "clearance = " + std::to_string(params.clearance) +
                          " m must lie below the distance field's truncation esdf.max_distance = " +
                          std::to_string(esdf.max_distance) +
                          " m (the collision cost needs distances up to the clearance)");
  }
}

LocalPlanner::LocalPlanner(const LocalPlannerOptions& options)
    : options_(options), searcher_(options.search) {
  options_.Validate();
}

std::optional<PlanningQuery> LocalPlanner::MakeQuery(
    const LocalMap& map, const Eigen::Vector3d& p0_W, const Eigen::Vector3d& v0_W,
    const Eigen::Vector3d& a0_W, const Eigen::Vector3d& mission_goal_W, const PlannerParams& params,
    const Trajectory* previous, double previous_time, PathSearchResult* front_end) {
  options_.CheckParams(params);
  PathSearchResult path = searcher_.Plan(map, p0_W, mission_goal_W, params.h_pl);
  const bool ok = path.ok() && path.waypoints.size() >= 2;
  if (front_end != nullptr) *front_end = path;
  if (!ok) return std::nullopt;

  PlanningQuery q;
  q.p0_W = p0_W;
  q.v0_W = v0_W;
  q.a0_W = a0_W;
  q.goal_W = path.waypoints.back();
  q.goal_is_mission_goal = path.goal_is_mission_goal;
  q.initial_path_W = std::move(path.waypoints);
  q.initial_path_W.front() = p0_W;  // the optimiser starts exactly at the drone's reference
  q.params = params;
  if (!q.goal_is_mission_goal) {
    const std::size_t n = q.initial_path_W.size();
    const Eigen::Vector3d last = q.initial_path_W[n - 1] - q.initial_path_W[n - 2];
    double speed = params.v_des;
    if (options_.goal_braking) {
      const double d = (mission_goal_W - q.goal_W).norm();
      speed = std::min(speed, std::sqrt(2.0 * params.a_max * d));
    }
    if (last.norm() > 1e-6) q.goal_v_W = speed * last.normalized();
  }
  if (previous != nullptr && !previous->Empty()) {
    q.previous = *previous;
    q.previous_time = previous_time;
  }
  Eigen::AlignedBox3d box;
  for (const auto& w : q.initial_path_W) box.extend(w);
  // Stopping from v0 may overshoot the start a little; include that region too.
  box.extend(p0_W + v0_W * (v0_W.norm() / (2.0 * params.a_max)));
  const double margin = params.clearance + options_.field_margin;
  box.min() -= Eigen::Vector3d::Constant(margin);
  box.max() += Eigen::Vector3d::Constant(margin);
  if (options_.snapshot == QuerySnapshot::kOccupancy) {
    q.occupancy = std::make_shared<const LocalMap>(map);
    return q;
  }
  q.field = builder_.Build(map, box, options_.esdf);
  return q;
}

}  // namespace quadtune::planning
