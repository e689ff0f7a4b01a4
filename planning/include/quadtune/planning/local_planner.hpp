#pragma once
/// \file
/// One planning step of the online planner, split so that it can be recorded and replayed:
///
///  1. LocalPlanner::MakeQuery — the front end (local goal at the horizon h_pl, A* on the inflated
///     local map, pruning) and a distance-field snapshot of the region around the path, packed into
///     a self-contained PlanningQuery;
///  2. TrajectoryBackend::Solve (trajectory_backend.hpp) — a back end on that query with a given
///     θ_s, retried up to PlannerParams::max_attempts times before the plan counts as failed
///     (the Ipopt back end's SolveQuery, ipopt/ipopt_backend.hpp; the EGO back end's
///     EgoBackend::Solve, ego/ego_optimizer.hpp).
///
/// A PlanningQuery is a value: any thread can re-solve it later with other short-term parameters
/// θ_s = {w_col, w_dyn, n_pol}; that is exactly what a short-term evaluation does (paper Sec.
/// III-B). Step 1 depends only on the map and the long-term parameters, never on θ_s, so a
/// recorded query is a faithful replay of the planner's decision problem.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/planning/esdf.hpp"
#include "quadtune/planning/local_map.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/path_search.hpp"
#include "quadtune/planning/plan_result.hpp"
#include "quadtune/planning/trajectory.hpp"

namespace quadtune::planning {

/// Which map snapshot a planning query carries (the back end's choice, TrajectoryBackend).
enum class QuerySnapshot {
  kDistanceField,  ///< PlanningQuery::field: a distance field around the path (Ipopt back end)
  kOccupancy,      ///< PlanningQuery::occupancy: a copy of the local map (EGO back end)
};
constexpr auto EnumNames(QuerySnapshot) {
  return std::array{EnumName{QuerySnapshot::kDistanceField, "distance_field"},
                    EnumName{QuerySnapshot::kOccupancy, "occupancy"}};
}

/// A self-contained, copyable record of one planning problem (world frame W, SI units).
///
/// Thread safety: a value; concurrent const use (re-solving from many threads) is safe.
struct PlanningQuery {
  std::uint64_t sequence = 0;  ///< index of the query within its flight
  double time = 0.0;           ///< flight time when the planner met this problem (s)
  Eigen::Vector3d p0_W = Eigen::Vector3d::Zero();  ///< start position (m)
  Eigen::Vector3d v0_W = Eigen::Vector3d::Zero();  ///< start velocity (m/s)
  Eigen::Vector3d a0_W = Eigen::Vector3d::Zero();  ///< start acceleration (m/s²)
  Eigen::Vector3d goal_W = Eigen::Vector3d::Zero();  ///< local goal (m)
  bool goal_is_mission_goal = false;  ///< the local goal is the mission waypoint itself
  /// Velocity at the local goal (m/s): zero at a mission waypoint; elsewhere v_des along the
  /// last segment of the front-end path, so the drone keeps flying through the horizon (as
  /// EGO-Planner does) instead of stopping at every local goal.
  Eigen::Vector3d goal_v_W = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> initial_path_W;  ///< pruned front-end path, start → goal (m)
  Esdf field;  ///< distance-field snapshot around the path (QuerySnapshot::kDistanceField)
  /// Occupancy snapshot: the local map as it was (QuerySnapshot::kOccupancy; null otherwise).
  /// Shared and immutable, so copies of the query are cheap.
  std::shared_ptr<const LocalMap> occupancy;
  std::optional<Trajectory> previous;           ///< the executing trajectory, for warm starts
  double previous_time = 0.0;                   ///< time on `previous` matching p0_W (s)
  /// Parameters in force when the query was made: θ_l and the fixed ones matter; θ_s is what a
  /// short-term evaluation replaces.
  PlannerParams params;
  /// PlanRequest::braking_deceleration of the request (m/s², 0: off): set by callers that
  /// re-plan with a v_des below the start speed (the online adaptation's slower trials).
  double braking_deceleration = 0.0;

  /// Approximate bytes held (distance field and paths).
  [[nodiscard]] std::size_t MemoryBytes() const;
};

/// The outcome of one planning step: the final attempt's result and the totals over attempts.
struct PlanOutcome {
  PlanResult result;          ///< the successful attempt, or the last failed one
  int attempts = 0;           ///< back-end solves run (0 when the front end failed)
  int failed_attempts = 0;    ///< n_s of this step: failed planning trials (paper Sec. III-D)
  double solve_time_s = 0.0;  ///< wall-clock t_c summed over attempts (s)
  double compute_units = 0.0; ///< deterministic cost summed over attempts (see PlanResult)
  std::string front_end_message;  ///< set when the front end failed

  [[nodiscard]] bool Ok() const { return result.Ok(); }
};

/// Settings of the planning step (not tuned by the experiments).
struct LocalPlannerOptions {
  PathSearchOptions search;
  EsdfOptions esdf;
  /// The distance-field box is the path's bounding box widened by clearance + this (m), >= 0.
  double field_margin = 1.0;
  /// Slow-down of the time allocation per extra retry: speed_scale = factor^(k−1) on attempt
  /// k ≥ 2 (the limits stay v_des and a_max).
  double retry_slowdown = 0.75;
  /// Factor on w_col for the attempts after one whose plan came too close to an obstacle,
  /// [1, 1e6] (1: off). The collision cost is a penalty: with a small w_col the optimum may cut
  /// into the clearance by a few millimetres, and a drone hovering just outside it then fails
  /// the same way on every re-plan until the flight stalls (docs/design.md, "Safety nets").
  double retry_collision_gain = 10.0;
  /// Braking for the mission goal (EGO-Planner's local-target rule): a local goal on the
  /// horizon whose distance d to the mission goal is within stopping distance gets the terminal
  /// speed min(v_des, sqrt(2 a_max d)) instead of v_des, so that the last plans before the goal
  /// can stop there. false: every horizon goal is reached at v_des.
  bool goal_braking = false;
  /// The map snapshot MakeQuery records (the Replanner sets it from its back end).
  QuerySnapshot snapshot = QuerySnapshot::kDistanceField;

  /// Throws ConfigError(origin, key, ...) for the first bad field.
  void Validate(const std::string& origin = "") const;
  /// Throws ConfigError(origin, key "clearance") when params.clearance is not below the distance
  /// field's truncation (esdf.max_distance). LocalPlanner::MakeQuery and the Replanner call it;
  /// experiment readers call it to reject such a file before any flight.
  void CheckParams(const PlannerParams& params, const std::string& origin = "") const;
};

/// The front end and snapshot maker, with reusable scratch memory.
///
/// Thread safety: one LocalPlanner per thread or flight.
class LocalPlanner {
 public:
  explicit LocalPlanner(const LocalPlannerOptions& options = {});

  /// Front end + distance-field snapshot for a plan from (p0, v0, a0) towards mission_goal_W.
  /// Returns nullopt and fills *front_end when the front end fails (no free local goal, no
  /// path); that failure counts as a failed planning trial.
  [[nodiscard]] std::optional<PlanningQuery> MakeQuery(
      const LocalMap& map, const Eigen::Vector3d& p0_W, const Eigen::Vector3d& v0_W,
      const Eigen::Vector3d& a0_W, const Eigen::Vector3d& mission_goal_W,
      const PlannerParams& params, const Trajectory* previous, double previous_time,
      PathSearchResult* front_end = nullptr);

  [[nodiscard]] const LocalPlannerOptions& options() const { return options_; }

 private:
  LocalPlannerOptions options_;
  PathSearcher searcher_;
  EsdfBuilder builder_;
};

}  // namespace quadtune::planning
