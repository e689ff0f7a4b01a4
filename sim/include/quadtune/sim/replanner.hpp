#pragma once
/// \file
/// The online replanning state machine, in the style of EGO-Planner's FSM:
///
///   kWaitMission ─StartMission→ kGenNewTraj ─plan ok→ kExecTraj ─waypoint reached→ kGenNewTraj …
///                                                     │  every t_pl (not within
///                                                     │  no_replan_near_goal of the waypoint),
///                                                     │  or when the executing trajectory hits
///                                                     │  the latest map → re-plan; a failed
///                                                     │  re-plan keeps the old trajectory
///                                                     └─ collision predicted within τ_c and the
///                                                        re-plan failed → kEmergencyStop (brake
///                                                        to hover) → kGenNewTraj once stopped
///   last waypoint reached → kDone
///
/// A re-plan that starts (nearly) at rest and whose every back-end attempt fails flies the front
/// end's path stop-and-go instead, when that passes the back end's check (the back end's
/// Fallback(), for the Ipopt back end planning::StopAndGoAlongPath; ReplannerOptions::
/// fallback_speed); its failed attempts still count in n_s.
///
/// Planning is instantaneous in simulated time (the simulation waits for the planner), so flights
/// are reproducible; the wall-clock solve time t_c is recorded beside the deterministic compute
/// units. Every plan is recorded (PlanRecord), and every planning query can be handed to an
/// observer (the engine's short-term optimiser replays them with other θ_s).
///
/// The FSM drives the planning library (quadtune::planning: local planner, back ends) and hands
/// the controller its reference (physics::TrackingReference); Fly (flight.hpp) closes the loop.
///
/// Thread safety: one Replanner per flight; not thread-safe.

#include <Eigen/Core>
#include <array>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/physics/controller.hpp"
#include "quadtune/planning/local_map.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/trajectory.hpp"
#include "quadtune/planning/trajectory_backend.hpp"
#include "quadtune/planning/ipopt/trajectory_optimizer.hpp"

namespace quadtune::sim {

/// States of the replanning FSM (see the file comment).
enum class ReplanState { kWaitMission, kGenNewTraj, kExecTraj, kEmergencyStop, kDone };
/// Short names of the states, e.g. "exec_traj".
constexpr auto EnumNames(ReplanState) {
  return std::array{EnumName{ReplanState::kWaitMission, "wait_mission"},
                    EnumName{ReplanState::kGenNewTraj, "gen_new_traj"},
                    EnumName{ReplanState::kExecTraj, "exec_traj"},
                    EnumName{ReplanState::kEmergencyStop, "emergency_stop"},
                    EnumName{ReplanState::kDone, "done"}};
}
using quadtune::ToString;

/// A plan that a PlanAdapter hands to the Replanner to execute from `start_time` on.
struct AdaptedPlan {
  double start_time = 0.0;         ///< flight time at which `outcome`'s trajectory starts (s)
  planning::PlanOutcome outcome;   ///< the chosen plan (its result must hold a trajectory)
  bool reaches_waypoint = false;   ///< the trajectory ends at the current mission waypoint
  planning::PlannerParams params;  ///< parameters to keep in force from now on (validated)
};

/// Optional hook that replaces the FSM's periodic re-planning by a plan chosen ahead of time
/// (the paper's online adaptation in changing environments, Sec. IV-B). Without an adapter the
/// FSM behaves exactly as described in the file comment.
///
/// Thread safety: called only from the Replanner's thread.
class PlanAdapter {
 public:
  virtual ~PlanAdapter() = default;
  /// A planned trajectory started executing at t0 (a plan of the FSM or one the adapter handed
  /// over); any earlier trajectory is no longer executed.
  virtual void OnTrajectory(double t0, const planning::Trajectory& trajectory,
                            bool reaches_waypoint, const planning::PlannerParams& params) = 0;
  /// Called on every tick while a trajectory executes (after the waypoint check, before the
  /// collision check) with the latest map and the current mission waypoint. A plan returned here
  /// is executed at once.
  virtual std::optional<AdaptedPlan> OnTick(double t, const planning::LocalMap& map,
                                            const Eigen::Vector3d& waypoint_W) = 0;
  /// While true, the FSM skips its periodic (every t_pl) re-plans; re-plans triggered by a
  /// predicted collision or a finished trajectory still happen.
  [[nodiscard]] virtual bool HoldsPeriodicReplan() const = 0;
};

/// FSM settings (not tuned by the experiments).
struct ReplannerOptions {
  double check_interval = 0.05;  ///< collision check of the executing trajectory every (s), > 0
  double check_dt = 0.05;        ///< sample spacing of that check along the trajectory (s), > 0
  double retry_interval = 0.1;   ///< wait after a failed plan before trying again (s), >= 0
  /// Plan from the measured state (not the reference) when the tracking error exceeds this (m).
  double tracking_replan_error = 0.6;
  double yaw_rate_max = 2.0;  ///< heading rate limit of the reference (rad/s), > 0
  double brake_factor = 0.8;  ///< emergency braking uses this fraction of a_max, (0, 1]
  /// Stop-and-go fallback (planning::StopAndGoAlongPath): when every back-end attempt of a plan
  /// that starts slower than `fallback_start_speed` (m/s, >= 0) fails, the drone flies the front
  /// end's path instead, at a peak speed of `fallback_speed` (m/s, >= 0, capped at v_des), if
  /// that passes the back end's acceptance check. The failed attempts still count in n_s.
  /// fallback_speed = 0 turns it off.
  double fallback_speed = 0.5;
  double fallback_start_speed = 0.3;
  /// Slowing down when v_des drops below the drone's speed (a parameter provider or an adapter
  /// lowered it): a plan that starts faster than v_des asks the back end to brake at
  /// slow_down_fraction · a_max (PlanningQuery::braking_deceleration), and one that then
  /// exceeds v_des is accepted when it stays inside that braking envelope
  /// (planning::BrakingEnvelopeViolation with slow_down_tolerance, sampled every
  /// slow_down_check_dt s). 0 (the default): off, such a plan fails the speed limit and the
  /// drone cannot slow down by re-planning. slow_down_fraction in [0, 1], the tolerance >= 0,
  /// the check step > 0.
  double slow_down_fraction = 0.0;
  double slow_down_tolerance = 0.05;
  double slow_down_check_dt = 0.01;

  /// Throws ConfigError(origin, key, ...) for the first bad field.
  void Validate(const std::string& origin = "") const;
};

/// One planning step as the flight saw it.
struct PlanRecord {
  double time = 0.0;                 ///< flight time of the step (s)
  bool ok = false;                   ///< a trajectory was produced
  bool collision_triggered = false;  ///< triggered by a predicted collision
  int failed_attempts = 0;           ///< n_s of the step (front-end failure counts as 1)
  double solve_time_s = 0.0;         ///< wall-clock t_c over attempts (s)
  double compute_units = 0.0;        ///< deterministic cost over attempts
  planning::PlanStatus status = planning::PlanStatus::kInvalidInput;  ///< last back-end status
  std::string message;                                                ///< failure detail
  planning::Trajectory trajectory;  ///< the new trajectory (empty on failure)
  double min_clearance = 0.0;       ///< of the planned trajectory (m)
  double jerk = 0.0;                ///< ∫|jerk|² of the planned trajectory
  double duration = 0.0;            ///< duration of the planned trajectory (s)
  /// The trajectory is the stop-and-go fallback (ok; the back end's attempts all failed).
  bool fallback = false;
};

/// The replanning FSM. See the file comment.
class Replanner {
 public:
  /// Plans with the Ipopt back end (IpoptBackend). `optimizer` must outlive the Replanner.
  /// Validates all options and `params`.
  Replanner(const planning::TrajectoryOptimizer& optimizer, const planning::PlannerParams& params,
            const ReplannerOptions& options = {},
            const planning::LocalPlannerOptions& planner_options = {});
  /// Plans with any back end; its queries record the back end's snapshot (planner_options'
  /// `snapshot` is replaced by backend.Snapshot()); its Fallback() replaces the stop-and-go
  /// fallback. `backend` must outlive the Replanner. Validates all options and `params`.
  Replanner(const planning::TrajectoryBackend& backend, const planning::PlannerParams& params,
            const ReplannerOptions& options = {},
            const planning::LocalPlannerOptions& planner_options = {});

  /// Starts a mission through `waypoints_W` from rest at p_W with heading yaw at time t.
  void StartMission(std::vector<Eigen::Vector3d> waypoints_W, const Eigen::Vector3d& p_W,
                    double yaw, double t);
  /// Replaces the parameters used by the following plans (validated).
  void SetParams(const planning::PlannerParams& params);
  [[nodiscard]] const planning::PlannerParams& params() const { return params_; }

  /// Called before each plan with the time and the parameters, which it may change (the engine
  /// injects the short-term optimiser's current best θ_s this way).
  void SetParamsProvider(
      std::function<void(double time, planning::PlannerParams& params)> provider);
  /// Called after each plan that reached the back end, with its query and outcome.
  void SetQueryObserver(
      std::function<void(const planning::PlanningQuery&, const planning::PlanOutcome&)> observer);
  /// Installs an adapter (not owned; nullptr removes it). It must outlive the flight.
  void SetAdapter(PlanAdapter* adapter) { adapter_ = adapter; }

  /// Advances the FSM at time t (s) given the measured position and velocity; `map` must hold the
  /// latest scans.
  void Tick(double t, const Eigen::Vector3d& p_W, const Eigen::Vector3d& v_W,
            const planning::LocalMap& map);

  /// The tracking reference at time t (for the controller). Heading follows the direction of
  /// motion with a rate limit, so calls must come with non-decreasing t.
  [[nodiscard]] physics::TrackingReference Reference(double t);
  /// Position reference at t (m), without side effects.
  [[nodiscard]] Eigen::Vector3d ReferencePosition(double t) const;
  /// Jerk of the reference at t (m/s³).
  [[nodiscard]] Eigen::Vector3d ReferenceJerk(double t) const;

  [[nodiscard]] ReplanState state() const { return state_; }
  [[nodiscard]] bool Done() const { return state_ == ReplanState::kDone; }
  /// Time the last waypoint was reached (s); valid when Done().
  [[nodiscard]] double mission_end_time() const { return end_time_; }
  [[nodiscard]] int emergency_stops() const { return emergency_stops_; }
  /// Index of the waypoint being approached.
  [[nodiscard]] std::size_t waypoint_index() const { return waypoint_; }
  [[nodiscard]] const std::vector<PlanRecord>& records() const { return records_; }
  [[nodiscard]] const planning::Trajectory& trajectory() const { return traj_; }
  [[nodiscard]] double trajectory_start() const { return traj_t0_; }

 private:
  Replanner(std::unique_ptr<const planning::TrajectoryBackend> owned,
            const planning::TrajectoryBackend* backend, const planning::PlannerParams& params,
            const ReplannerOptions& options, const planning::LocalPlannerOptions& planner_options);
  bool PlanFrom(double t, const Eigen::Vector3d& p0, const Eigen::Vector3d& v0,
                const Eigen::Vector3d& a0, const planning::LocalMap& map, bool from_trajectory,
                bool collision_triggered);
  std::optional<double> TimeToCollision(const planning::LocalMap& map, double tau) const;
  void EmergencyStop(double t, const Eigen::Vector3d& p, const Eigen::Vector3d& v,
                     const Eigen::Vector3d& a);
  // Executes a plan handed over by the adapter.
  void Adopt(double t, AdaptedPlan plan);

  std::unique_ptr<const planning::TrajectoryBackend>
      owned_backend_;  // the planning::IpoptBackend of the first ctor
  const planning::TrajectoryBackend& backend_;
  planning::PlannerParams params_;
  ReplannerOptions options_;
  planning::LocalPlanner planner_;
  std::function<void(double, planning::PlannerParams&)> provider_;
  std::function<void(const planning::PlanningQuery&, const planning::PlanOutcome&)> observer_;
  PlanAdapter* adapter_ = nullptr;

  ReplanState state_ = ReplanState::kWaitMission;
  std::vector<Eigen::Vector3d> waypoints_;
  std::size_t waypoint_ = 0;
  planning::Trajectory traj_;  // executing trajectory (empty: hold hold_p_)
  double traj_t0_ = 0.0;       // its start time (s)
  bool traj_reaches_waypoint_ = false;
  Eigen::Vector3d hold_p_ = Eigen::Vector3d::Zero();
  double last_plan_time_ = 0.0;
  double next_try_time_ = 0.0;
  double next_check_time_ = 0.0;
  double end_time_ = 0.0;
  int emergency_stops_ = 0;
  std::uint64_t sequence_ = 0;
  std::vector<PlanRecord> records_;
  double yaw_ = 0.0;       // heading of the reference (rad)
  double yaw_time_ = 0.0;  // time of the last Reference() call (s)
};

}  // namespace quadtune::sim
