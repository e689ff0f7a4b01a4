#include "quadtune/sim/flight.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <nlohmann/json.hpp>

#include "quadtune/common/error.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/planning/ipopt/ipopt_backend.hpp"

namespace quadtune::sim {

Mission Mission::GoAndReturn(const Eigen::Vector3d& start_W, const Eigen::Vector3d& goal_W) {
  return Mission{
      start_W, {goal_W, start_W}, std::atan2(goal_W.y() - start_W.y(), goal_W.x() - start_W.x())};
}

Mission Mission::GoTo(const Eigen::Vector3d& start_W, const Eigen::Vector3d& goal_W) {
  return Mission{start_W, {goal_W}, std::atan2(goal_W.y() - start_W.y(), goal_W.x() - start_W.x())};
}

void Mission::Validate(const std::string& origin) const {
  if (waypoints_W.empty())
    throw ConfigError(origin, "mission.waypoints", "needs at least one waypoint");
  for (int k = 0; k < 3; ++k) CheckInRange(start_W[k], Range::Any(), origin, "mission.start");
  for (std::size_t i = 0; i < waypoints_W.size(); ++i) {
    for (int k = 0; k < 3; ++k) {
      CheckInRange(waypoints_W[i][k], Range::Any(), origin,
                   "mission.waypoints[" + std::to_string(i) + "]");
    }
  }
  CheckInRange(start_yaw, Range::Any(), origin, "mission.start_yaw");
}

physics::DepthSensorOptions FlightOptions::DefaultSensor() {
  physics::DepthSensorOptions s;
  s.width = 48;
  s.height = 32;
  s.rate_hz = 15.0;
  s.max_range = 5.0;
  return s;
}

void FlightPlannerOptions::Validate(const std::string& origin) const {
  optimizer.Validate(origin);
  planning::LocalPlannerOptions::Validate(origin);
}

void FlightOptions::Validate(const std::string& origin) const {
  sensor.Validate(origin);
  map.Validate(origin);
  planner.Validate(origin);
  replanner.Validate(origin);
  CheckInRange(tick_rate_hz, {1.0, 10000.0, false, false}, origin, "tick_rate_hz");
  CheckInRange(max_time, Range::Positive(), origin, "max_time");
  CheckInRange(log_rate_hz, Range::NonNegative(), origin, "log_rate_hz");
  CheckInRange(tracking_window, Range::Positive(), origin, "tracking_window");
  CheckInRange(stall_time, Range::Positive(), origin, "stall_time");
  CheckInRange(stall_distance, Range::NonNegative(), origin, "stall_distance");
}

StallDetector::StallDetector(double stall_time, double stall_distance, double t0,
                             const Eigen::Vector3d& p0_W, std::size_t waypoint)
    : stall_time_(stall_time),
      stall_distance_(stall_distance),
      check_time_(t0 + stall_time),
      p_start_W_(p0_W),
      waypoint_(waypoint) {}

std::optional<double> StallDetector::Update(double t, const Eigen::Vector3d& p_W,
                                            std::size_t waypoint) {
  if (waypoint != waypoint_) {
    waypoint_ = waypoint;
  } else if (t >= check_time_) {
    const double moved = (p_W - p_start_W_).norm();
    if (moved < stall_distance_) return moved;
  } else {
    return std::nullopt;
  }
  p_start_W_ = p_W;
  check_time_ = t + stall_time_;
  return std::nullopt;
}

FlightResult Fly(physics::World& world, const Mission& mission,
                 const planning::PlannerParams& params, const FlightOptions& options,
                 const planning::TrajectoryOptimizer& optimizer, const FlightHooks& hooks) {
  return Fly(world, mission, params, options, planning::IpoptBackend(optimizer), hooks);
}

namespace {

// The FSM and metric tick must divide the world's physics rate.
void CheckTickRate(const physics::World& world, const FlightOptions& options) {
  const double physics_rate = world.options().physics_rate_hz;
  const double ratio = physics_rate / options.tick_rate_hz;
  if (std::abs(ratio - std::round(ratio)) > 1e-9 || ratio < 1.0) {
    throw ConfigError(
        "", "tick_rate_hz",
        "must divide the world's physics rate (" + std::to_string(physics_rate) + " Hz)");
  }
}

// Why the flight ends before this tick's physics step (sets status and message), or false.
// Checked in order: mission done, cancelled, max_time, stalled.
bool EndsHere(double t, const physics::World& world, const Replanner& replanner,
              const FlightOptions& options, const FlightHooks& hooks, StallDetector& stall,
              FlightMetrics& m) {
  if (replanner.Done()) {
    m.status = FlightStatus::kCompleted;
    return true;
  }
  if (hooks.cancelled && hooks.cancelled()) {
    m.status = FlightStatus::kCancelled;
    m.message = "cancelled";
    return true;
  }
  if (t >= options.max_time) {
    m.status = FlightStatus::kTimeout;
    m.message = "mission not finished within max_time";
    return true;
  }
  if (const std::optional<double> moved =
          stall.Update(t, world.State().p_W, replanner.waypoint_index())) {
    m.status = FlightStatus::kStalled;
    m.message = "no progress: moved " + std::to_string(*moved) + " m in the last " +
                std::to_string(options.stall_time) + " s";
    return true;
  }
  return false;
}

// Tracking, smoothness, distance, speed and clearance metrics after each physics step, and the
// flight log at options.log_rate_hz.
class FlightRecorder {
 public:
  FlightRecorder(const FlightOptions& options, const physics::World& world,
                 const Mission& mission, FlightResult* result)
      : result_(result),
        dt_(1.0 / options.tick_rate_hz),
        log_every_(options.log_rate_hz > 0.0
                       ? std::max<std::int64_t>(
                             1, std::llround(options.tick_rate_hz / options.log_rate_hz))
                       : 0),
        window_ticks_(std::max<std::int64_t>(
            1, std::llround(options.tracking_window * options.tick_rate_hz))),
        drone_radius_(world.drone().BoundingRadius()),
        last_p_(mission.start_W) {
    result_->metrics.min_clearance = std::numeric_limits<double>::infinity();
  }

  [[nodiscard]] double dt() const { return dt_; }

  void AfterStep(std::int64_t tick, const physics::World& world, const Replanner& replanner) {
    FlightMetrics& m = result_->metrics;
    const double t1 = world.time();
    const physics::DroneState s = world.State();
    const Eigen::Vector3d p_ref = replanner.ReferencePosition(t1);
    const double err = (s.p_W - p_ref).norm();
    error_sum_ += err;
    m.max_tracking_error = std::max(m.max_tracking_error, err);
    window_max_ = std::max(window_max_, err);
    if ((tick + 1) % window_ticks_ == 0) {
      m.window_tracking_error.push_back(window_max_);
      window_max_ = 0.0;
    }
    m.jerk_integral += replanner.ReferenceJerk(t1).squaredNorm() * dt_;
    m.distance += (s.p_W - last_p_).norm();
    last_p_ = s.p_W;
    m.max_speed = std::max(m.max_speed, s.v_W.norm());
    m.min_clearance =
        std::min(m.min_clearance, world.obstacles().Distance(s.p_W) - drone_radius_);
    if (log_every_ > 0 && tick % log_every_ == 0) Log(t1, s, p_ref, world, replanner);
  }

  // The metrics that need the whole flight: flight time, counts, means, plan statistics.
  void Finish(std::int64_t ticks, const physics::World& world, const Replanner& replanner) {
    FlightMetrics& m = result_->metrics;
    if (window_max_ > 0.0) m.window_tracking_error.push_back(window_max_);
    m.flight_time =
        m.status == FlightStatus::kCompleted ? replanner.mission_end_time() : world.time();
    m.collisions = static_cast<int>(world.collisions().Count());
    m.emergency_stops = replanner.emergency_stops();
    m.mean_tracking_error = ticks > 0 ? error_sum_ / static_cast<double>(ticks) : 0.0;
    result_->plans = replanner.records();
    double solve_sum = 0.0;
    for (const auto& r : result_->plans) {
      ++m.plans;
      if (!r.ok) ++m.failed_plans;
      if (r.fallback) ++m.fallback_plans;
      m.failed_attempts += r.failed_attempts;
      solve_sum += r.solve_time_s;
      m.max_solve_time = std::max(m.max_solve_time, r.solve_time_s);
      m.compute_units += r.compute_units;
    }
    m.mean_solve_time = m.plans > 0 ? solve_sum / m.plans : 0.0;
    m.mean_speed = m.flight_time > 0.0 ? m.distance / m.flight_time : 0.0;
    if (!std::isfinite(m.min_clearance)) m.min_clearance = 0.0;
  }

 private:
  void Log(double t1, const physics::DroneState& s, const Eigen::Vector3d& p_ref,
           const physics::World& world, const Replanner& replanner) {
    FlightLogRow row;
    row.t = t1;
    row.p_W = s.p_W;
    row.v_W = s.v_W;
    row.p_ref_W = p_ref;
    const double tau = t1 - replanner.trajectory_start();
    row.v_ref_W = replanner.trajectory().Empty() || tau >= replanner.trajectory().Duration()
                      ? Eigen::Vector3d::Zero()
                      : replanner.trajectory().Velocity(tau);
    row.yaw = s.Yaw();
    row.state = replanner.state();
    row.collisions = static_cast<int>(world.collisions().Count());
    row.v_des = replanner.params().v_des;
    result_->log.push_back(row);
  }

  FlightResult* result_;
  double dt_;
  std::int64_t log_every_;
  std::int64_t window_ticks_;
  double drone_radius_;
  double error_sum_ = 0.0;
  double window_max_ = 0.0;
  Eigen::Vector3d last_p_;
};

}  // namespace

FlightResult Fly(physics::World& world, const Mission& mission,
                 const planning::PlannerParams& params, const FlightOptions& options,
                 const planning::TrajectoryBackend& backend, const FlightHooks& hooks) {
  mission.Validate();
  params.Validate();
  options.Validate();
  CheckTickRate(world, options);

  const auto wall_start = std::chrono::steady_clock::now();
  FlightResult result;
  FlightMetrics& m = result.metrics;

  world.Reset(physics::DroneState::Hover(world.drone(), mission.start_W, mission.start_yaw,
                                         world.options().gravity));
  physics::DepthSensor sensor(options.sensor, DeriveSeed(world.options().seed, {0x5e7501}));
  planning::LocalMapOptions map_options = options.map;
  map_options.resolution = params.map_resolution;
  map_options.inflation = params.inflation;
  planning::LocalMap map(map_options, mission.start_W);
  Replanner replanner(backend, params, options.replanner, options.planner);
  if (hooks.params_provider) replanner.SetParamsProvider(hooks.params_provider);
  if (hooks.on_plan) replanner.SetQueryObserver(hooks.on_plan);
  if (hooks.adapter != nullptr) replanner.SetAdapter(hooks.adapter);
  replanner.StartMission(mission.waypoints_W, mission.start_W, mission.start_yaw, world.time());
  world.SetReference([&replanner](double t) { return replanner.Reference(t); });

  FlightRecorder recorder(options, world, mission, &result);
  physics::DepthScan scan;
  StallDetector stall(options.stall_time, options.stall_distance, world.time(), world.State().p_W,
                      replanner.waypoint_index());
  std::int64_t tick = 0;
  m.status = FlightStatus::kTimeout;
  try {
    for (;; ++tick) {
      const double t = world.time();
      if (sensor.Update(world, scan)) {
        map.MoveTo(world.State().p_W);
        map.Insert(scan.origin_W, scan.hits_W);
      }
      const physics::DroneState& measured = world.MeasuredState();
      replanner.Tick(t, measured.p_W, measured.v_W, map);
      if (EndsHere(t, world, replanner, options, hooks, stall, m)) break;
      world.Advance(recorder.dt());
      if (world.HasDiverged()) {
        m.status = FlightStatus::kDiverged;
        m.message = "the simulation diverged";
        break;
      }
      recorder.AfterStep(tick, world, replanner);
    }
  } catch (const std::exception& e) {
    m.status = FlightStatus::kError;
    m.message = e.what();
  }
  recorder.Finish(tick, world, replanner);
  m.wall_time =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return result;
}

namespace {
nlohmann::json ToJson(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
}  // namespace

void WriteFlightLog(const std::string& directory, const FlightResult& result,
                    const physics::ObstacleSet& obstacles) {
  namespace fs = std::filesystem;
  fs::create_directories(directory);
  const fs::path dir(directory);
  {
    std::ofstream out(dir / "flight.csv");
    out.precision(9);
    out << "t,x,y,z,vx,vy,vz,ref_x,ref_y,ref_z,ref_vx,ref_vy,ref_vz,yaw,state,collisions\n";
    for (const auto& r : result.log) {
      out << r.t << ',' << r.p_W.x() << ',' << r.p_W.y() << ',' << r.p_W.z() << ',' << r.v_W.x()
          << ',' << r.v_W.y() << ',' << r.v_W.z() << ',' << r.p_ref_W.x() << ',' << r.p_ref_W.y()
          << ',' << r.p_ref_W.z() << ',' << r.v_ref_W.x() << ',' << r.v_ref_W.y() << ','
          << r.v_ref_W.z() << ',' << r.yaw << ',' << static_cast<int>(r.state) << ','
          << r.collisions << '\n';
    }
  }
  {
    std::ofstream out(dir / "plans.csv");
    out.precision(9);
    out << "plan,t0,t,x,y,z,vx,vy,vz\n";
    int id = 0;
    for (const auto& p : result.plans) {
      if (!p.ok || p.trajectory.Empty()) continue;
      for (const auto& s : p.trajectory.Sample(0.05)) {
        out << id << ',' << p.time << ',' << p.time + s.t << ',' << s.p_W.x() << ',' << s.p_W.y()
            << ',' << s.p_W.z() << ',' << s.v_W.x() << ',' << s.v_W.y() << ',' << s.v_W.z() << '\n';
      }
      ++id;
    }
  }
  {
    // One row per planning step: what the planner decided and why a step failed.
    std::ofstream out(dir / "plan_steps.csv");
    out.precision(9);
    out << "time,ok,collision_triggered,failed_attempts,status,solve_time_s,compute_units,"
           "min_clearance,duration,message\n";
    for (const auto& p : result.plans) {
      std::string message = p.message;
      for (char& ch : message) {
        if (ch == ',' || ch == '\n') ch = ';';
      }
      out << p.time << ',' << (p.ok ? 1 : 0) << ',' << (p.collision_triggered ? 1 : 0) << ','
          << p.failed_attempts << ',' << ToString(p.status) << ',' << p.solve_time_s << ','
          << p.compute_units << ',' << p.min_clearance << ',' << p.duration << ',' << message
          << '\n';
    }
  }
  {
    nlohmann::json j;
    j["cylinders"] = nlohmann::json::array();
    for (const auto& c : obstacles.cylinders) {
      j["cylinders"].push_back({{"x", c.center_W.x()},
                                {"y", c.center_W.y()},
                                {"radius", c.radius},
                                {"z_min", c.z_min},
                                {"z_max", c.z_max}});
    }
    j["rings"] = nlohmann::json::array();
    for (const auto& r : obstacles.rings) {
      j["rings"].push_back({{"x", r.center_W.x()},
                            {"y", r.center_W.y()},
                            {"z", r.center_W.z()},
                            {"yaw", r.yaw},
                            {"radius", r.radius},
                            {"thickness", r.thickness}});
    }
    j["ground"] = obstacles.ground;
    std::ofstream(dir / "obstacles.json") << j.dump(1) << '\n';
  }
}

void WriteFlightFiles(const std::string& directory, const FlightResult& result,
                      const physics::ObstacleSet& obstacles, const Mission& mission) {
  WriteFlightLog(directory, result, obstacles);
  {
    const FlightMetrics& m = result.metrics;
    nlohmann::json j = {
        {"status", ToString(m.status)},
        {"message", m.message},
        {"flight_time", m.flight_time},
        {"collisions", m.collisions},
        {"emergency_stops", m.emergency_stops},
        {"max_tracking_error", m.max_tracking_error},
        {"mean_tracking_error", m.mean_tracking_error},
        {"plans", m.plans},
        {"failed_plans", m.failed_plans},
        {"failed_attempts", m.failed_attempts},
        {"fallback_plans", m.fallback_plans},
        {"mean_solve_time", m.mean_solve_time},
        {"max_solve_time", m.max_solve_time},
        {"compute_units", m.compute_units},
        {"jerk_integral", m.jerk_integral},
        {"min_clearance", m.min_clearance},
        {"distance", m.distance},
        {"mean_speed", m.mean_speed},
        {"max_speed", m.max_speed},
        {"wall_time", m.wall_time},
        {"start", ToJson(mission.start_W)},
        {"goal", ToJson(mission.waypoints_W.front())},
    };
    std::ofstream(std::filesystem::path(directory) / "summary.json") << j.dump(1) << '\n';
  }
}

}  // namespace quadtune::sim
