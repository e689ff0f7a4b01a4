#pragma once
/// \file
/// A waypoint planner: a trajectory back end written outside quadtune against its installed
/// headers (find_package(quadtune)), flown in quadtune's closed loop by engine::BackendPlanner.
///
/// Solve() takes the vertices of the query's front-end path (the A* path through the local map,
/// pruned) and n_pol - 1 more points that split it into n_pol parts of equal arc length, and
/// joins them by quintic pieces: the first starts in the query's state (p0, v0, a0), the last
/// ends at the local goal with the query's goal velocity, the inner points are passed at the
/// cruise speed along the chord of their neighbours with zero acceleration, and each piece takes
/// the longest of: its length at the mean speed of its ends (at least half the cruise speed),
/// twice its velocity change over a_max, and WaypointOptions::min_piece_time. The curve is accepted when its samples (every
/// WaypointOptions::check_dt) stay outside the inflated local map (after leaving it, when the
/// start lies inside) and within v_des and a_max (+ limit_tolerance). The first attempt cruises
/// at v_des, each further one (up to max_attempts) at retry_slowdown times the previous speed.
///
/// Parameters (PlannerParams names): θ_s = n_pol (more points hold the curve closer to the path
/// and slow it down on short pieces); θ_l = v_des (cruise speed) and the loop's h_pl and t_pl;
/// w_col and w_dyn are not used. No fallback.
///
/// Thread safety: immutable; Solve() reads only the query (its occupancy snapshot) and the
/// parameters, so concurrent re-solves are safe and equal to serial ones.

#include <optional>
#include <string>

#include "quadtune/planning/trajectory_backend.hpp"

namespace own_planner {

/// Settings of WaypointBackend (not tuned).
struct WaypointOptions {
  double check_dt = 0.02;         ///< acceptance-check sample spacing (s), > 0
  double limit_tolerance = 0.05;  ///< relative tolerance on v_des and a_max, >= 0
  double min_piece_time = 0.05;   ///< shortest piece duration (s), > 0

  /// Throws quadtune::ConfigError(origin, key, ...) for a value outside its range.
  void Validate(const std::string& origin) const;
};

/// The waypoint planner (see the file comment).
class WaypointBackend final : public quadtune::planning::TrajectoryBackend {
 public:
  /// Validates `options`.
  explicit WaypointBackend(const WaypointOptions& options, const std::string& origin);

  [[nodiscard]] std::string Name() const override { return "waypoint"; }
  [[nodiscard]] quadtune::planning::QuerySnapshot Snapshot() const override {
    return quadtune::planning::QuerySnapshot::kOccupancy;
  }
  [[nodiscard]] quadtune::planning::PlanOutcome Solve(
      const quadtune::planning::PlanningQuery& query,
      const quadtune::planning::PlannerParams& params,
      const quadtune::planning::LocalPlannerOptions& options) const override;
  [[nodiscard]] std::optional<quadtune::planning::PlanResult> Fallback(
      const quadtune::planning::PlanningQuery& /*query*/,
      const quadtune::planning::PlannerParams& /*params*/, double /*speed*/) const override {
    return std::nullopt;
  }

 private:
  WaypointOptions options_;
};

}  // namespace own_planner
