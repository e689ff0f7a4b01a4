#include "quadtune/sim/replanner.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/planning/ipopt/ipopt_backend.hpp"
#include "quadtune/planning/quintic.hpp"

namespace quadtune::sim {

using planning::IpoptBackend;
using planning::LocalMap;
using planning::LocalPlannerOptions;
using planning::PathSearchResult;
using planning::PlannerParams;
using planning::PlanningQuery;
using planning::PlanOutcome;
using planning::PlanResult;
using planning::Trajectory;
using planning::TrajectoryBackend;
using planning::TrajectoryOptimizer;

void ReplannerOptions::Validate(const std::string& origin) const {
  CheckInRange(check_interval, Range::Positive(), origin, "check_interval");
  CheckInRange(check_dt, Range::Positive(), origin, "check_dt");
  CheckInRange(retry_interval, Range::NonNegative(), origin, "retry_interval");
  CheckInRange(tracking_replan_error, Range::Positive(), origin, "tracking_replan_error");
  CheckInRange(yaw_rate_max, Range::Positive(), origin, "yaw_rate_max");
  CheckInRange(brake_factor, {0.0, 1.0, true, false}, origin, "brake_factor");
  CheckInRange(fallback_speed, Range::NonNegative(), origin, "fallback_speed");
  CheckInRange(fallback_start_speed, Range::NonNegative(), origin, "fallback_start_speed");
  CheckInRange(slow_down_fraction, Range::Closed(0.0, 1.0), origin, "slow_down_fraction");
  CheckInRange(slow_down_tolerance, Range::NonNegative(), origin, "slow_down_tolerance");
  CheckInRange(slow_down_check_dt, Range::Positive(), origin, "slow_down_check_dt");
}

namespace {

LocalPlannerOptions WithSnapshot(LocalPlannerOptions options, const TrajectoryBackend& backend) {
  options.snapshot = backend.Snapshot();
  return options;
}

}  // namespace

Replanner::Replanner(const TrajectoryOptimizer& optimizer, const PlannerParams& params,
                     const ReplannerOptions& options, const LocalPlannerOptions& planner_options)
    : Replanner(std::make_unique<IpoptBackend>(optimizer), nullptr, params, options,
                planner_options) {}

Replanner::Replanner(const TrajectoryBackend& backend, const PlannerParams& params,
                     const ReplannerOptions& options, const LocalPlannerOptions& planner_options)
    : Replanner(nullptr, &backend, params, options, planner_options) {}

Replanner::Replanner(std::unique_ptr<const TrajectoryBackend> owned,
                     const TrajectoryBackend* backend, const PlannerParams& params,
                     const ReplannerOptions& options, const LocalPlannerOptions& planner_options)
    : owned_backend_(std::move(owned)),
      backend_(backend != nullptr ? *backend : *owned_backend_),
      params_(params),
      options_(options),
      planner_(WithSnapshot(planner_options, backend_)) {
  params_.Validate();
  options_.Validate();
  planner_.options().CheckParams(params_);
}

void Replanner::SetParams(const PlannerParams& params) {
  params.Validate();
  params_ = params;
}

void Replanner::SetParamsProvider(std::function<void(double, PlannerParams&)> provider) {
  provider_ = std::move(provider);
}

void Replanner::SetQueryObserver(
    std::function<void(const PlanningQuery&, const PlanOutcome&)> observer) {
  observer_ = std::move(observer);
}

void Replanner::StartMission(std::vector<Eigen::Vector3d> waypoints_W, const Eigen::Vector3d& p_W,
                             double yaw, double t) {
  if (waypoints_W.empty()) throw std::invalid_argument("Replanner: a mission needs a waypoint");
  waypoints_ = std::move(waypoints_W);
  waypoint_ = 0;
  traj_ = Trajectory();
  hold_p_ = p_W;
  yaw_ = yaw;
  yaw_time_ = t;
  last_plan_time_ = t;
  next_try_time_ = t;
  next_check_time_ = t;
  emergency_stops_ = 0;
  sequence_ = 0;
  records_.clear();
  state_ = ReplanState::kGenNewTraj;
}

Eigen::Vector3d Replanner::ReferencePosition(double t) const {
  if (traj_.Empty()) return hold_p_;
  return traj_.Position(t - traj_t0_);
}

Eigen::Vector3d Replanner::ReferenceJerk(double t) const {
  if (traj_.Empty()) return Eigen::Vector3d::Zero();
  const double tau = t - traj_t0_;
  if (tau >= traj_.Duration()) return Eigen::Vector3d::Zero();
  return traj_.Jerk(tau);
}

physics::TrackingReference Replanner::Reference(double t) {
  physics::TrackingReference ref;
  if (traj_.Empty()) {
    ref.p_W = hold_p_;
  } else {
    const double tau = t - traj_t0_;
    ref.p_W = traj_.Position(tau);
    if (tau < traj_.Duration()) {
      ref.v_W = traj_.Velocity(tau);
      ref.a_W = traj_.Acceleration(tau);
      ref.j_W = traj_.Jerk(tau);
    }
  }
  // Heading along the horizontal direction of motion, rate-limited.
  const double dt = std::max(0.0, t - yaw_time_);
  yaw_time_ = t;
  if (ref.v_W.head<2>().norm() > 0.3) {
    const double target = std::atan2(ref.v_W.y(), ref.v_W.x());
    double diff = std::remainder(target - yaw_, 2.0 * std::numbers::pi);
    const double step = options_.yaw_rate_max * dt;
    diff = std::clamp(diff, -step, step);
    yaw_ = std::remainder(yaw_ + diff, 2.0 * std::numbers::pi);
    ref.yaw_rate = dt > 0.0 ? diff / dt : 0.0;
  }
  ref.yaw = yaw_;
  return ref;
}

std::optional<double> Replanner::TimeToCollision(const LocalMap& map, double tau) const {
  if (traj_.Empty()) return std::nullopt;
  const double T = traj_.Duration();
  for (double s = std::max(0.0, tau); s <= T + 1e-9; s += options_.check_dt) {
    if (map.IsOccupied(traj_.Position(std::min(s, T)))) return s - tau;
  }
  return std::nullopt;
}

bool Replanner::PlanFrom(double t, const Eigen::Vector3d& p0, const Eigen::Vector3d& v0,
                         const Eigen::Vector3d& a0, const LocalMap& map, bool from_trajectory,
                         bool collision_triggered) {
  if (provider_) {
    provider_(t, params_);
    params_.Validate();
  }
  PlanRecord rec;
  rec.time = t;
  rec.collision_triggered = collision_triggered;
  PathSearchResult front_end;
  const Trajectory* previous = from_trajectory && !traj_.Empty() ? &traj_ : nullptr;
  std::optional<PlanningQuery> query = planner_.MakeQuery(
      map, p0, v0, a0, waypoints_[waypoint_], params_, previous, t - traj_t0_, &front_end);
  if (!query) {
    rec.failed_attempts = 1;
    rec.message = "front end: " + front_end.message;
    records_.push_back(std::move(rec));
    return false;
  }
  query->sequence = sequence_++;
  query->time = t;
  const double v_start = v0.norm();
  const bool slowing = options_.slow_down_fraction > 0.0 && v_start > params_.v_des;
  if (slowing) query->braking_deceleration = options_.slow_down_fraction * params_.a_max;
  PlanOutcome outcome = backend_.Solve(*query, params_, planner_.options());
  if (slowing && outcome.result.status == planning::PlanStatus::kDynamicsViolated) {
    const std::string why = planning::BrakingEnvelopeViolation(
        outcome.result.trajectory, v_start, params_.v_des, params_.a_max,
        options_.slow_down_fraction, options_.slow_down_tolerance, options_.slow_down_check_dt);
    if (why.empty()) {
      outcome.result.status = planning::PlanStatus::kSuccess;
      outcome.result.message = "slowing down from " + FormatNumber(v_start) + " m/s";
    } else {
      outcome.result.message += "; slowing down from " + FormatNumber(v_start) + " m/s: " + why;
    }
  }
  if (observer_) observer_(*query, outcome);

  rec.ok = outcome.Ok();
  rec.failed_attempts = outcome.failed_attempts;
  rec.solve_time_s = outcome.solve_time_s;
  rec.compute_units = outcome.compute_units;
  rec.status = outcome.result.status;
  rec.min_clearance = outcome.result.min_clearance;
  rec.jerk = outcome.result.cost.jerk;
  rec.duration = outcome.result.duration;
  if (!rec.ok && options_.fallback_speed > 0.0 && v0.norm() < options_.fallback_start_speed) {
    std::optional<PlanResult> fallback =
        backend_.Fallback(*query, params_, options_.fallback_speed);
    if (fallback && fallback->Ok()) {
      rec.ok = true;
      rec.fallback = true;
      rec.status = fallback->status;
      rec.message =
          "stop-and-go fallback (the back end's last attempt: " + outcome.result.message + ")";
      rec.min_clearance = fallback->min_clearance;
      rec.jerk = fallback->cost.jerk;
      rec.duration = fallback->duration;
      outcome.result = std::move(*fallback);
    }
  }
  if (!rec.ok) {
    rec.message = outcome.result.message;
    records_.push_back(std::move(rec));
    return false;
  }
  traj_ = outcome.result.trajectory;
  traj_t0_ = t;
  traj_reaches_waypoint_ = query->goal_is_mission_goal;
  last_plan_time_ = t;
  rec.trajectory = traj_;
  records_.push_back(std::move(rec));
  state_ = ReplanState::kExecTraj;
  if (adapter_ != nullptr) adapter_->OnTrajectory(t, traj_, traj_reaches_waypoint_, params_);
  return true;
}

void Replanner::Adopt(double t, AdaptedPlan plan) {
  plan.params.Validate();
  QT_DEMAND(plan.outcome.Ok() && !plan.outcome.result.trajectory.Empty(),
            "an adapted plan must hold a trajectory");
  params_ = plan.params;
  PlanRecord rec;
  rec.time = plan.start_time;
  rec.ok = true;
  rec.failed_attempts = plan.outcome.failed_attempts;
  rec.solve_time_s = plan.outcome.solve_time_s;
  rec.compute_units = plan.outcome.compute_units;
  rec.status = plan.outcome.result.status;
  rec.min_clearance = plan.outcome.result.min_clearance;
  rec.jerk = plan.outcome.result.cost.jerk;
  rec.duration = plan.outcome.result.duration;
  traj_ = std::move(plan.outcome.result.trajectory);
  traj_t0_ = plan.start_time;
  traj_reaches_waypoint_ = plan.reaches_waypoint;
  last_plan_time_ = t;
  rec.trajectory = traj_;
  records_.push_back(std::move(rec));
  state_ = ReplanState::kExecTraj;
  adapter_->OnTrajectory(traj_t0_, traj_, traj_reaches_waypoint_, params_);
}

void Replanner::EmergencyStop(double t, const Eigen::Vector3d& p, const Eigen::Vector3d& v,
                              const Eigen::Vector3d& a) {
  ++emergency_stops_;
  traj_ = planning::BrakingTrajectory(p, v, a, options_.brake_factor * params_.a_max);
  traj_t0_ = t;
  traj_reaches_waypoint_ = false;
  state_ = ReplanState::kEmergencyStop;
}

void Replanner::Tick(double t, const Eigen::Vector3d& p_W, const Eigen::Vector3d& v_W,
                     const LocalMap& map) {
  switch (state_) {
    case ReplanState::kWaitMission:
    case ReplanState::kDone:
      return;

    case ReplanState::kGenNewTraj: {
      if (t < next_try_time_) return;
      if (!traj_.Empty()) hold_p_ = ReferencePosition(t);
      traj_ = Trajectory();
      if (!PlanFrom(t, p_W, v_W, Eigen::Vector3d::Zero(), map, false, false)) {
        next_try_time_ = t + options_.retry_interval;
      }
      return;
    }

    case ReplanState::kEmergencyStop: {
      if (t - traj_t0_ >= traj_.Duration()) {
        state_ = ReplanState::kGenNewTraj;
        next_try_time_ = t;
      }
      return;
    }

    case ReplanState::kExecTraj: {
      const double tau = t - traj_t0_;
      const Eigen::Vector3d& waypoint = waypoints_[waypoint_];
      const bool finished = tau >= traj_.Duration();
      if (traj_reaches_waypoint_ && finished && (p_W - waypoint).norm() <= params_.goal_tolerance) {
        ++waypoint_;
        if (waypoint_ >= waypoints_.size()) {
          end_time_ = t;
          hold_p_ = traj_.Position(traj_.Duration());
          state_ = ReplanState::kDone;
        } else {
          state_ = ReplanState::kGenNewTraj;
          next_try_time_ = t;
        }
        return;
      }

      if (adapter_ != nullptr) {
        if (std::optional<AdaptedPlan> plan = adapter_->OnTick(t, map, waypoint)) {
          Adopt(t, std::move(*plan));
          return;
        }
      }
      std::optional<double> collision_in;
      if (t >= next_check_time_) {
        next_check_time_ = t + options_.check_interval;
        collision_in = TimeToCollision(map, tau);
      }
      const bool periodic = (adapter_ == nullptr || !adapter_->HoldsPeriodicReplan()) &&
                            t - last_plan_time_ >= params_.t_pl &&
                            (p_W - waypoint).norm() > params_.no_replan_near_goal;
      // A finished local trajectory that did not bring the drone to its waypoint: plan again.
      const bool stalled = finished;
      if (!collision_in && !periodic && !stalled) return;
      if (!collision_in && t < next_try_time_) return;

      const Eigen::Vector3d p_ref = traj_.Position(tau);
      const bool track_ok = (p_W - p_ref).norm() <= options_.tracking_replan_error;
      bool ok = false;
      if (track_ok && !finished) {
        ok = PlanFrom(t, p_ref, traj_.Velocity(tau), traj_.Acceleration(tau), map, true,
                      collision_in.has_value());
      } else {
        ok = PlanFrom(t, p_W, v_W, Eigen::Vector3d::Zero(), map, false, collision_in.has_value());
      }
      if (!ok) {
        next_try_time_ = t + options_.retry_interval;
        if (collision_in && *collision_in < params_.tau_c) {
          const bool on_traj = track_ok && !finished;
          EmergencyStop(t, on_traj ? p_ref : p_W, on_traj ? traj_.Velocity(tau) : v_W,
                        on_traj ? traj_.Acceleration(tau) : Eigen::Vector3d::Zero());
        }
      }
      return;
    }
  }
}

}  // namespace quadtune::sim
