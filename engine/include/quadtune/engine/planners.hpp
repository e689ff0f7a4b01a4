#pragma once
/// \file
/// The planner plug-ins shipped with the engine:
///
/// - IpoptPlanner: the project's online planner (physics::World + sim::Fly, Ipopt back end,
///   planning::SolveQuery for re-solves). θ_s = {w_col, w_dyn, n_pol}, θ_l = {v_des, h_pl, t_pl}.
/// - BackendPlanner: any planning::TrajectoryBackend in IpoptPlanner's closed loop (sensing, local
///   map, FSM, physics), with the θ_s and θ_l names of IpoptPlanner; the back end gives them its
///   meaning. IpoptPlanner and EgoPlanner are BackendPlanners; so is a back end of one's own
///   (docs/own-planner.md).
/// - EgoPlanner: a BackendPlanner with EGO-Planner's B-spline back end (planning::EgoBackend,
///   L-BFGS, ESDF-free collision term); recorded queries carry an occupancy snapshot. θ_s =
///   {w_col = λ_c, w_dyn = λ_d, n_pol (B-spline spans over the horizon, in groups of
///   EgoOptions::segments_per_pol)}, θ_l = {v_des, h_pl, t_pl}.
/// - ToyPlanner: a deliberately simple 1-D planner (a point moving along a line through gates)
///   with its own parameter names, to show that the engine tunes any plug-in. θ_s = {gain,
///   max_iter}, θ_l = {speed, margin}.
/// - SleepPlanner: a scale model of IpoptPlanner's cost for distributed runs: flights and
///   re-solves sleep for seeded log-normal durations (no core used), so that many ranks on a few
///   cores load rank 0 as that many cores would. θ_s = {effort}, θ_l = {pace}.
///
/// Thread safety: all are immutable after construction; all members are safe to call
/// concurrently on distinct WorkerSlots.

#include <memory>
#include <string>
#include <vector>

#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/planner.hpp"
#include "quadtune/engine/planner_registry.hpp"
#include "quadtune/layout/options.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/world.hpp"
#include "quadtune/planning/ego_optimizer.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/trajectory_backend.hpp"
#include "quadtune/planning/trajectory_optimizer.hpp"
#include "quadtune/sim/flight.hpp"
#include "quadtune/sim/scenario.hpp"

namespace quadtune::engine {

/// Settings of IpoptPlanner.
struct IpoptPlannerOptions {
  physics::DroneDescription drone;       ///< the drone flown
  physics::WorldOptions world;           ///< world options (seed replaced per flight)
  layout::LayoutOptions layout;          ///< layout generator options; one map per map seed
  sim::MissionKind mission = sim::MissionKind::kGoAndReturn;  ///< over the layout's start and goal
  sim::FlightOptions flight;        ///< flight settings (max_time, …)
  planning::PlannerParams base;          ///< fixed parameters and defaults of the tunables

  /// Reads an experiment's `planner:` map (keys drone, layout | layout_file, world, mission,
  /// max_time, fixed, safety_nets, and `type`); relative file names resolve as ResolvePath does
  /// against `base_dir`. `extra_keys` are further keys the caller reads itself (a back end's own
  /// options); any other key throws ConfigError naming it.
  static IpoptPlannerOptions FromYaml(const YamlMap& planner, const std::string& base_dir,
                                      const std::vector<std::string>& extra_keys = {});
};

/// ParameterInfo of the PlannerParams `names`: default from `values`, range and integer flag
/// from planning::ParameterRange and planning::ParameterIsInteger.
std::vector<ParameterInfo> PlannerParamsInfo(const planning::PlannerParams& values,
                                             const std::vector<std::string>& names);

/// A trajectory back end flown in the project's closed loop, as a plug-in: PrepareMap generates
/// the layout with the map seed and builds its shared obstacle geometry; each WorkerSlot holds one
/// physics::World that is Reset() onto the requested map's geometry; Fly() flies sim::Fly with the back
/// end in the slot's physics::World, and Resolve() re-solves a recorded planning::PlanningQuery
/// with TrajectoryBackend::Solve. θ_s = {w_col, w_dyn, n_pol}, θ_l = {v_des, h_pl, t_pl}
/// (PlannerParams), defaults from `options.base`. The back end must follow the rules of
/// trajectory_backend.hpp (deterministic, thread-safe, queries hold all a re-solve reads).
class BackendPlanner {
 public:
  /// `name` is what Name() returns; `backend` must not be null.
  BackendPlanner(std::string name, IpoptPlannerOptions options,
                 std::shared_ptr<const planning::TrajectoryBackend> backend);

  std::string Name() const { return name_; }
  std::vector<ParameterInfo> ShortTermParameters() const;
  std::vector<ParameterInfo> LongTermParameters() const;
  Opaque PrepareMap(std::uint64_t map_seed) const;
  FlightRecord Fly(const FlightRequest& request, WorkerSlot& slot) const;
  ResolveRecord Resolve(const Opaque& query, const ParamValues& theta_s) const;

  [[nodiscard]] const IpoptPlannerOptions& options() const { return *options_; }
  [[nodiscard]] const planning::TrajectoryBackend& backend() const { return *backend_; }

  /// The parameter schema of every BackendPlanner: θ_s and θ_l with
  /// PlannerParams' ranges, integer flags and defaults; what a back end's registration gives.
  static PlannerSchema Schema();

 private:
  std::string name_;
  std::shared_ptr<const IpoptPlannerOptions> options_;
  std::shared_ptr<const planning::TrajectoryBackend> backend_;
};

/// The project's Ipopt planner: a BackendPlanner named "ipopt" over a planning::IpoptBackend (the
/// minimum-jerk optimiser on the distance field, retries, stop-and-go fallback) that owns its
/// TrajectoryOptimizer, built from `options.flight.planner.optimizer`.
class IpoptPlanner : public BackendPlanner {
 public:
  explicit IpoptPlanner(IpoptPlannerOptions options);
};

/// A planning::IpoptBackend that owns its TrajectoryOptimizer, built from `options` (the default:
/// sim::FlightOptions' optimiser settings, as IpoptPlanner flies by default).
[[nodiscard]] std::shared_ptr<const planning::TrajectoryBackend> MakeIpoptBackend(
    const planning::TrajectoryOptimizerOptions& options = sim::FlightOptions{}.planner.optimizer);

/// Settings of EgoPlanner: the flight setting of IpoptPlanner (its `flight.planner.optimizer` is
/// unused) and the EGO back end's.
struct EgoPlannerOptions {
  IpoptPlannerOptions common;
  planning::EgoOptions ego;
};

/// EGO-Planner's back end in the project's closed loop: a BackendPlanner named "ego" over a
/// planning::EgoBackend (re-solves bit-reproducible on any thread).
class EgoPlanner : public BackendPlanner {
 public:
  explicit EgoPlanner(EgoPlannerOptions options);

  [[nodiscard]] const planning::EgoOptions& ego_options() const { return ego_; }

 private:
  planning::EgoOptions ego_;
};

/// Settings of ToyPlanner.
struct ToyPlannerOptions {
  double length = 20.0;        ///< track length (m), > 0
  int gates = 6;               ///< gates along the track, >= 0; each has a random speed limit
  double gate_speed_min = 2.0; ///< gate speed limits are uniform in [min, max] (m/s)
  double gate_speed_max = 4.0;
  double plan_interval = 1.0;  ///< a planning query every this many metres (m), > 0
  double flight_delay_s = 0.0; ///< wall-clock sleep per flight (s), to simulate cost in tests
  /// Fly() throws std::runtime_error when θ_l's speed exceeds this (m/s); <= 0: never.
  double throw_speed_above = 0.0;
};

/// A 1-D toy planner. A point flies the track at `speed` (θ_l); before each gate it must be below
/// the gate's limit, else it collides (n_c += 1) unless `margin` (θ_l, m) lets it brake in time,
/// which costs an emergency stop. Each plan solves x = cos(x)-like fixed-point problem by the
/// damped iteration x ← x + gain·(g(x) − x) for at most max_iter iterations (θ_s); it fails
/// (n_s += 1) when it does not converge; compute units = iterations.
class ToyPlanner {
 public:
  explicit ToyPlanner(ToyPlannerOptions options = {});

  std::string Name() const { return "toy"; }
  std::vector<ParameterInfo> ShortTermParameters() const;
  std::vector<ParameterInfo> LongTermParameters() const;
  Opaque PrepareMap(std::uint64_t map_seed) const;
  FlightRecord Fly(const FlightRequest& request, WorkerSlot& slot) const;
  ResolveRecord Resolve(const Opaque& query, const ParamValues& theta_s) const;

 private:
  ToyPlannerOptions options_;
};

/// Settings of SleepPlanner: log-normal durations given by their median and 95th percentile (s).
/// Defaults from the Ipopt planner on the 2-core development machine: a re-solve of a recorded
/// query median 1 ms, p95 2 ms (README, `recorded_bench`: 0.6–1.1 ms medians, p95 0.9–2.3 ms); a
/// flight median 0.22 s (docs/results/scaling/bench.csv: 4.5 flights/s on one thread), p95 twice
/// that; about 50 planning queries per flight (164 queries in three 1.3 m forest flights).
struct SleepPlannerOptions {
  double resolve_median_s = 0.001;  ///< > 0
  double resolve_p95_s = 0.002;     ///< >= resolve_median_s
  double flight_median_s = 0.22;    ///< > 0
  double flight_p95_s = 0.44;       ///< >= flight_median_s
  int queries_per_flight = 50;      ///< >= 1
};

/// Sleeps instead of computing. Fly() sleeps a duration drawn from the flight distribution with
/// the flight's seed, in one step per planning query, reporting each query; Resolve() sleeps a
/// duration drawn from the re-solve distribution with a seed of (query, θ_s), stretched by
/// 0.5 + 0.25·(effort + 1/effort) (so effort = 1 is the cheapest) and reports that duration as
/// its compute units (1 unit = 0.1 ms), so reproducible-mode objectives are deterministic. A
/// re-solve succeeds when effort reaches the query's difficulty (uniform in [0.5, 1.5]); a flight
/// takes 20/pace s of flight time and collides once for each of 5 gates whose limit (uniform in
/// [1.5, 3]) pace exceeds.
class SleepPlanner {
 public:
  explicit SleepPlanner(SleepPlannerOptions options = {});

  std::string Name() const { return "sleep"; }
  std::vector<ParameterInfo> ShortTermParameters() const;
  std::vector<ParameterInfo> LongTermParameters() const;
  Opaque PrepareMap(std::uint64_t map_seed) const;
  FlightRecord Fly(const FlightRequest& request, WorkerSlot& slot) const;
  ResolveRecord Resolve(const Opaque& query, const ParamValues& theta_s) const;

 private:
  SleepPlannerOptions options_;
};

}  // namespace quadtune::engine
