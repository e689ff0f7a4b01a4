#pragma once
/// \file
/// One closed-loop flight: the Bullet world (physics, controller), the depth sensor, the local
/// map and the replanning FSM, stepped together until the mission ends. Its metrics are the
/// long-term objective's inputs (paper Sec. III-D, IV-A): flight time t_f, collisions n_c,
/// emergency stops n_e, tracking error J_p, and the per-plan t_c and n_s; plus the
/// changing-environment terms (∫|jerk|² dt of the executed reference, smallest clearance).
///
/// Loop, every 1/tick_rate_hz of simulated time: scan when the sensor is due → move the map
/// window to the drone and insert the scan → FSM tick on the measured state → advance the world
/// (the controller follows the FSM's reference at its own rate) → metrics and log.
///
/// Thread safety: Fly() uses only its arguments; flights on different Worlds may run
/// concurrently (the optimiser is shared read-only).

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/physics/depth_sensor.hpp"
#include "quadtune/physics/world.hpp"
#include "quadtune/planning/ipopt/trajectory_optimizer.hpp"
#include "quadtune/planning/local_map.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/sim/replanner.hpp"

namespace quadtune::sim {

/// Where to fly: from rest at start_W through the waypoints in order.
struct Mission {
  Eigen::Vector3d start_W = Eigen::Vector3d(0.0, 0.0, 1.0);  ///< (m)
  std::vector<Eigen::Vector3d> waypoints_W;                  ///< (m), at least one
  double start_yaw = 0.0;                                    ///< (rad)

  /// The paper's benchmark mission: to `goal_W` and back to `start_W`.
  static Mission GoAndReturn(const Eigen::Vector3d& start_W, const Eigen::Vector3d& goal_W);
  /// To `goal_W` only.
  static Mission GoTo(const Eigen::Vector3d& start_W, const Eigen::Vector3d& goal_W);
  /// Throws ConfigError for no waypoints or non-finite points.
  void Validate(const std::string& origin = "") const;
};

/// How a flight ended.
enum class FlightStatus {
  kCompleted,  ///< every waypoint reached
  kTimeout,    ///< max_time passed first
  kStalled,    ///< no progress: moved less than stall_distance within stall_time
  kDiverged,   ///< the simulation diverged (non-finite state, drone far away)
  kError,      ///< an exception inside the flight (message says which)
  kCancelled,  ///< stopped by the cancel hook
};
/// Short names, e.g. "completed", as stored with the results.
constexpr auto EnumNames(FlightStatus) {
  return std::array{EnumName{FlightStatus::kCompleted, "completed"},
                    EnumName{FlightStatus::kTimeout, "timeout"},
                    EnumName{FlightStatus::kStalled, "stalled"},
                    EnumName{FlightStatus::kDiverged, "diverged"},
                    EnumName{FlightStatus::kError, "error"},
                    EnumName{FlightStatus::kCancelled, "cancelled"}};
}
using quadtune::ToString;

/// Settings of the closed loop's planning step: those of every back end (the base) and the Ipopt
/// back end's solver settings, which the Ipopt planner builds its optimiser from and the online
/// adaptation's braking check reads its limits' tolerance and sampling from.
struct FlightPlannerOptions : planning::LocalPlannerOptions {
  planning::TrajectoryOptimizerOptions optimizer;

  /// Throws ConfigError(origin, key, ...) for the first bad field (the optimiser's first).
  void Validate(const std::string& origin = "") const;
};

/// Settings of a flight (not tuned by the experiments).
struct FlightOptions {
  physics::DepthSensorOptions sensor = DefaultSensor();
  planning::LocalMapOptions map;  ///< resolution and inflation are taken from the parameters
  FlightPlannerOptions planner;
  ReplannerOptions replanner;
  double tick_rate_hz = 100.0;   ///< FSM and metric rate (Hz), must divide the physics rate
  double max_time = 120.0;       ///< flight time limit (s), > 0
  double log_rate_hz = 20.0;     ///< state log rate (Hz); 0: no state log
  double tracking_window = 1.0;  ///< window of the windowed tracking error J_p (s), > 0
  /// A flight whose drone moved less than stall_distance (m) in the last stall_time (s) ends as
  /// kStalled: stuck hovering (every plan failing) it would only burn compute until max_time.
  /// The window restarts whenever a mission waypoint is reached (StallDetector).
  /// stall_time > 0 (a value >= max_time disables it), stall_distance >= 0.
  double stall_time = 15.0;
  double stall_distance = 1.0;

  /// A 48×32 camera at 15 Hz, 5 m range: enough for 0.1 m maps, cheap enough for 100× real time.
  static physics::DepthSensorOptions DefaultSensor();
  /// Throws ConfigError(origin, key, ...) for the first bad field.
  void Validate(const std::string& origin = "") const;
};

/// Metrics of a flight (SI units).
struct FlightMetrics {
  FlightStatus status = FlightStatus::kError;
  std::string message;
  double flight_time = 0.0;          ///< t_f: mission time, or time flown when not completed (s)
  int collisions = 0;                ///< n_c: contact episodes (obstacles and ground)
  int emergency_stops = 0;           ///< n_e
  double max_tracking_error = 0.0;   ///< max ‖p − p_ref‖ over the flight (m)
  double mean_tracking_error = 0.0;  ///< mean ‖p − p_ref‖ (m)
  std::vector<double> window_tracking_error;  ///< J_p per tracking_window (m)
  int plans = 0;                              ///< planning steps
  int failed_plans = 0;                       ///< planning steps that produced no trajectory
  int failed_attempts = 0;                    ///< Σ n_s over the steps
  int fallback_plans = 0;        ///< steps that flew the stop-and-go fallback (PlanRecord)
  double mean_solve_time = 0.0;  ///< mean t_c per step (s)
  double max_solve_time = 0.0;   ///< max t_c (s)
  double compute_units = 0.0;    ///< Σ deterministic compute units
  double jerk_integral = 0.0;    ///< ∫‖jerk of the executed reference‖² dt (m²/s⁵)
  double min_clearance = 0.0;    ///< smallest obstacle distance of the drone's surface (m)
  double distance = 0.0;         ///< path length flown (m)
  double mean_speed = 0.0;       ///< distance / flight_time (m/s)
  double max_speed = 0.0;        ///< (m/s)
  double wall_time = 0.0;        ///< wall-clock duration of Fly() (s)
};

/// One row of the state log.
struct FlightLogRow {
  double t = 0.0;
  Eigen::Vector3d p_W, v_W, p_ref_W, v_ref_W;
  double yaw = 0.0;
  ReplanState state = ReplanState::kWaitMission;
  int collisions = 0;
  double v_des = 0.0;  ///< desired velocity of the parameters in force (m/s)
};

/// Everything a flight produced.
struct FlightResult {
  FlightMetrics metrics;
  std::vector<FlightLogRow> log;  ///< at log_rate_hz
  std::vector<PlanRecord> plans;  ///< every planning step
};

/// Optional hooks into a flight.
struct FlightHooks {
  /// See Replanner::SetParamsProvider.
  std::function<void(double time, planning::PlannerParams& params)> params_provider;
  /// See Replanner::SetQueryObserver.
  std::function<void(const planning::PlanningQuery&, const planning::PlanOutcome&)> on_plan;
  /// Polled every tick; true stops the flight (kCancelled).
  std::function<bool()> cancelled;
  /// See Replanner::SetAdapter (not owned; must outlive Fly). nullptr: plain replanning.
  PlanAdapter* adapter = nullptr;
};

/// Fly()'s stall test (FlightOptions::stall_time, stall_distance): checked every stall_time
/// seconds, the flight has stalled when the drone is less than stall_distance from where it was
/// at the window's start. The window restarts at every check and whenever another mission
/// waypoint becomes current: a go-and-return flight that turns round within a window may end it
/// near where it began, having flown all the way.
class StallDetector {
 public:
  StallDetector(double stall_time, double stall_distance, double t0, const Eigen::Vector3d& p0_W,
                std::size_t waypoint);
  /// Feeds the state at time t; returns the distance moved in the window when it has stalled.
  std::optional<double> Update(double t, const Eigen::Vector3d& p_W, std::size_t waypoint);

 private:
  double stall_time_;
  double stall_distance_;
  double check_time_;
  Eigen::Vector3d p_start_W_;
  std::size_t waypoint_;
};

/// Flies `mission` in `world` (reset to hover at the mission start; its options, drone and
/// obstacles are kept) with `params`. Invalid arguments throw ConfigError; everything that goes
/// wrong during the flight is reported in the metrics (status, message), never thrown.
[[nodiscard]] FlightResult Fly(physics::World& world, const Mission& mission,
                               const planning::PlannerParams& params, const FlightOptions& options,
                               const planning::TrajectoryOptimizer& optimizer,
                               const FlightHooks& hooks = {});
/// The same flight with any trajectory back end (same sensing, map, FSM and physics; see
/// Replanner's back-end constructor).
[[nodiscard]] FlightResult Fly(physics::World& world, const Mission& mission,
                               const planning::PlannerParams& params, const FlightOptions& options,
                               const planning::TrajectoryBackend& backend,
                               const FlightHooks& hooks = {});

/// Writes a flight's log for people and plots into `directory` (created): flight.csv (state
/// log), plans.csv (planned trajectories sampled at 0.05 s), plan_steps.csv (every planning step:
/// outcome, failed attempts, status, t_c, failure message), obstacles.json. The figure script
/// reads these.
void WriteFlightLog(const std::string& directory, const FlightResult& result,
                    const physics::ObstacleSet& obstacles);

/// WriteFlightLog and summary.json (metrics, start and goal).
void WriteFlightFiles(const std::string& directory, const FlightResult& result,
                      const physics::ObstacleSet& obstacles, const Mission& mission);

}  // namespace quadtune::sim
