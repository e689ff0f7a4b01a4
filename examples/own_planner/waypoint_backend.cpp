#include "waypoint_backend.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "quadtune/common/yaml.hpp"
#include "quadtune/planning/local_map.hpp"

namespace own_planner {

namespace qp = quadtune::planning;
using Eigen::Vector3d;

void WaypointOptions::Validate(const std::string& origin) const {
  quadtune::CheckInRange(check_dt, quadtune::Range::Positive(), origin, "planner.waypoint.check_dt");
  quadtune::CheckInRange(limit_tolerance, quadtune::Range::NonNegative(), origin,
                         "planner.waypoint.limit_tolerance");
  quadtune::CheckInRange(min_piece_time, quadtune::Range::Positive(), origin,
                         "planner.waypoint.min_piece_time");
}

WaypointBackend::WaypointBackend(const WaypointOptions& options, const std::string& origin)
    : options_(options) {
  options_.Validate(origin);
}

namespace {

// The quintic on [0, T] from state (p0, v0, a0) to (p1, v1, a1), as Trajectory coefficients.
qp::Trajectory::Coefficients Quintic(const Vector3d& p0, const Vector3d& v0, const Vector3d& a0,
                                     const Vector3d& p1, const Vector3d& v1, const Vector3d& a1,
                                     double T) {
  const Vector3d dp = p1 - p0;
  qp::Trajectory::Coefficients c;
  c.col(0) = p0;
  c.col(1) = v0;
  c.col(2) = 0.5 * a0;
  c.col(3) = (20.0 * dp - (8.0 * v1 + 12.0 * v0) * T - (3.0 * a0 - a1) * T * T) / (2.0 * std::pow(T, 3));
  c.col(4) = (-30.0 * dp + (14.0 * v1 + 16.0 * v0) * T + (3.0 * a0 - 2.0 * a1) * T * T) /
             (2.0 * std::pow(T, 4));
  c.col(5) = (12.0 * dp - 6.0 * (v1 + v0) * T - (a0 - a1) * T * T) / (2.0 * std::pow(T, 5));
  return c;
}

// The vertices of the polyline `path` (at least two points) and `count` - 1 more points that
// split it into `count` parts of equal arc length, in order along the path.
std::vector<Vector3d> Waypoints(const std::vector<Vector3d>& path, int count) {
  std::vector<double> at{0.0};  // arc length at each vertex
  for (std::size_t i = 1; i < path.size(); ++i) at.push_back(at.back() + (path[i] - path[i - 1]).norm());
  const double min_gap = 1e-3 * at.back();
  std::vector<Vector3d> out{path.front()};
  double last = 0.0;  // arc length of out.back()
  std::size_t seg = 1;
  for (int k = 1; k <= count; ++k) {
    const double s = k == count ? at.back() : at.back() * k / count;
    for (; seg < path.size() && at[seg] <= s; ++seg) {  // vertices up to s
      if (at[seg] - last > min_gap) {
        out.push_back(path[seg]);
        last = at[seg];
      }
    }
    if (seg < path.size() && s - last > min_gap && at[seg] - s > min_gap) {
      const double f = (s - at[seg - 1]) / (at[seg] - at[seg - 1]);
      out.push_back(path[seg - 1] + f * (path[seg] - path[seg - 1]));
      last = s;
    }
  }
  out.back() = path.back();  // the goal itself, also when its vertex lay within min_gap
  return out;
}

// The trajectory through `points` at `speed` (see the file comment).
qp::Trajectory Through(const std::vector<Vector3d>& points, const qp::PlanningQuery& q,
                       double speed, double a_max, double min_piece_time) {
  const int n = static_cast<int>(points.size()) - 1;
  std::vector<Vector3d> v(points.size(), Vector3d::Zero());
  v.front() = q.v0_W;
  v.back() = q.goal_v_W;
  for (int k = 1; k < n; ++k) {
    const Vector3d chord = points[k + 1] - points[k - 1];
    if (chord.norm() > 1e-9) v[k] = speed * chord.normalized();
  }
  std::vector<double> durations;
  std::vector<qp::Trajectory::Coefficients> coefficients;
  for (int k = 0; k < n; ++k) {
    // Long enough to cover the piece at its mean end speed (at least half the cruise speed) and
    // to change the velocity at about half the acceleration limit.
    const double mean_speed = std::max(0.5 * (v[k].norm() + v[k + 1].norm()), 0.5 * speed);
    const double T = std::max({(points[k + 1] - points[k]).norm() / mean_speed,
                               2.0 * (v[k + 1] - v[k]).norm() / a_max, min_piece_time});
    const Vector3d a_start = k == 0 ? q.a0_W : Vector3d::Zero();
    durations.push_back(T);
    coefficients.push_back(
        Quintic(points[k], v[k], a_start, points[k + 1], v[k + 1], Vector3d::Zero(), T));
  }
  return qp::Trajectory(std::move(durations), std::move(coefficients));
}

// Samples the curve: status, limits, clearance. Returns the number of samples taken.
int Check(const qp::LocalMap& map, const qp::PlannerParams& params, const WaypointOptions& o,
          qp::PlanResult* r) {
  const qp::Trajectory& traj = r->trajectory;
  const std::vector<qp::TrajectorySample> samples = traj.Sample(o.check_dt);
  r->duration = traj.Duration();
  r->max_speed = 0.0;
  r->max_acceleration = 0.0;
  // Samples may lie in the inflated region the plan started in, until the first free one.
  const auto first_free = std::find_if(samples.begin(), samples.end(), [&](const auto& x) {
    return !map.IsOccupied(x.p_W);
  });
  const bool collision = std::any_of(first_free, samples.end(), [&](const auto& x) {
    return map.IsOccupied(x.p_W);
  });
  for (const qp::TrajectorySample& x : samples) {
    r->max_speed = std::max(r->max_speed, x.v_W.norm());
    r->max_acceleration = std::max(r->max_acceleration, x.a_W.norm());
  }
  // Outside the inflated map every sample is at least the inflation away from what was seen.
  r->min_clearance = collision ? 0.0 : map.options().inflation;
  r->cost.jerk = traj.JerkEnergy();
  if (collision) {
    r->status = qp::PlanStatus::kCollision;
    r->message = "the curve enters an inflated obstacle";
  } else if (r->max_speed > params.v_des * (1.0 + o.limit_tolerance) ||
             r->max_acceleration > params.a_max * (1.0 + o.limit_tolerance)) {
    r->status = qp::PlanStatus::kDynamicsViolated;
    r->message = "over the velocity or acceleration limit";
  } else {
    r->status = qp::PlanStatus::kSuccess;
    r->message.clear();
  }
  return static_cast<int>(samples.size());
}

}  // namespace

qp::PlanOutcome WaypointBackend::Solve(const qp::PlanningQuery& query,
                                       const qp::PlannerParams& params,
                                       const qp::LocalPlannerOptions& options) const {
  const auto started = std::chrono::steady_clock::now();
  qp::PlanOutcome out;
  std::vector<Vector3d> path = query.initial_path_W;
  if (path.size() < 2) path = {query.p0_W, query.goal_W};
  path.front() = query.p0_W;
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  if (query.occupancy == nullptr || !(length > 1e-3)) {
    out.result.status = qp::PlanStatus::kInvalidInput;
    out.result.message = query.occupancy == nullptr ? "the query has no occupancy snapshot"
                                                    : "the start is at the local goal";
    return out;
  }
  const std::vector<Vector3d> points = Waypoints(path, params.n_pol);
  double speed = params.v_des;
  for (int attempt = 0; attempt < params.max_attempts; ++attempt) {
    ++out.attempts;
    out.result = qp::PlanResult{};
    out.result.trajectory = Through(points, query, speed, params.a_max, options_.min_piece_time);
    const int samples = Check(*query.occupancy, params, options_, &out.result);
    // Deterministic work measure: 1 unit (0.1 ms nominal) per attempt and per 100 samples.
    out.result.compute_units = 1.0 + 0.01 * samples;
    out.compute_units += out.result.compute_units;
    if (out.Ok()) break;
    ++out.failed_attempts;
    speed *= options.retry_slowdown;
  }
  out.solve_time_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  out.result.solve_time_s = out.solve_time_s;
  return out;
}

}  // namespace own_planner
