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
///
/// Room engine/planners: its files include engine headers of this room, api only
/// (scripts/check_rooms.py; docs/design.md, "Architecture").
///
/// Thread safety: all are immutable after construction; all members are safe to call
/// concurrently on distinct WorkerSlots.

#include <memory>
#include <string>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/api/planner.hpp"
#include "quadtune/engine/api/planner_schema.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/layout/options.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/world.hpp"
#include "quadtune/planning/ego/ego_optimizer.hpp"
#include "quadtune/planning/ipopt/ipopt_backend.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/trajectory_backend.hpp"
#include "quadtune/sim/flight.hpp"
#include "quadtune/sim/scenario.hpp"

namespace quadtune::engine {

/// Settings of the closed loop every BackendPlanner flies (drone, world, layout, mission, flight,
/// fixed parameters), whatever its back end: IpoptPlanner, EgoPlanner and a back end of one's own
/// (docs/own-planner.md) read them from the `planner:` map alike.
struct ClosedLoopOptions {
  physics::DroneDescription drone;       ///< the drone flown
  physics::WorldOptions world;           ///< world options (seed replaced per flight)
  layout::LayoutOptions layout;          ///< layout generator options; one map per map seed
  sim::MissionKind mission = sim::MissionKind::kGoAndReturn;  ///< over the layout's start and goal
  sim::FlightOptions flight;        ///< flight settings (max_time, …)
  planning::PlannerParams base;          ///< fixed parameters and defaults of the tunables
  /// ego: a re-plan from (nearly) rest whose every attempt failed flies the front end's path
  /// stop-and-go instead (planning::EgoBackend::Fallback); the ipopt planner always does.
  bool ego_stop_and_go = false;

  /// Reads an experiment's `planner:` map (ClosedLoopFields); relative file names resolve as
  /// ResolvePath does against `base_dir`. `extra_keys` are further keys the caller reads itself
  /// (a back end's own options); any other key throws ConfigError naming it.
  static ClosedLoopOptions FromYaml(const YamlMap& planner, const std::string& base_dir,
                                      const std::vector<std::string>& extra_keys = {});
};

/// The `planner:` map of a planner flown in the closed loop (ipopt, ego) as ClosedLoopFields
/// reads it: the options, and the values they do not keep as written.
struct ClosedLoopSection {
  std::string base_dir = ".";  ///< folder relative file names resolve against (not a key)
  std::string type = "ipopt";  ///< `type` (the registry dispatches on it)
  std::string drone = "drones/research_1kg.yaml";  ///< `drone` as written
  std::string layout_file;  ///< `layout_file` as written; "" when `layout` gives the options
  bool safety_nets = true;
  ClosedLoopOptions options;
};

/// The keys of the `planner:` map: type, drone, layout | layout_file, world, mission, max_time,
/// fixed, safety_nets, ego_stop_and_go. Reading checks the fixed parameters only key by key; FromYaml then checks
/// them together (PlannerParams::Validate, CheckParams).
const Fields<ClosedLoopSection>& ClosedLoopFields();

/// ParameterInfo of the PlannerParams `names`: default from `values`, range and integer flag
/// from planning::ParameterRange and planning::ParameterIsInteger.
std::vector<ParameterInfo> PlannerParamsInfo(const planning::PlannerParams& values,
                                             const std::vector<std::string>& names);

/// A trajectory back end flown in the project's closed loop, as a plug-in: PrepareMap generates
/// the layout with the map seed and builds its shared obstacle geometry; each WorkerSlot holds one
/// physics::World that is Reset() onto the requested map's geometry; Fly() flies sim::Fly with the back
/// end in the slot's physics::World, and Resolve() re-solves a recorded planning::PlanningQuery
/// with TrajectoryBackend::Solve. A flight asked for its log (FlightRequest::log_directory)
/// writes flight.csv, plans.csv, plan_steps.csv, obstacles.json (sim::WriteFlightLog) and
/// layout.yaml, and gives the facts status, message, max_tracking_error, mean_tracking_error,
/// mean_solve_time, max_solve_time, distance, mean_speed, max_speed, start, goal (the mission's
/// first waypoint), obstacles (their count), drone, spacing_target, density_definition and
/// spacing_achieved (the layout's achieved spacing as its density definition measures it). θ_s = {w_col, w_dyn, n_pol}, θ_l = {v_des, h_pl, t_pl}
/// (PlannerParams), defaults from `options.base`. The back end must follow the rules of
/// trajectory_backend.hpp (deterministic, thread-safe, queries hold all a re-solve reads).
class BackendPlanner {
 public:
  /// `name` is what Name() returns; `backend` must not be null.
  BackendPlanner(std::string name, ClosedLoopOptions options,
                 std::shared_ptr<const planning::TrajectoryBackend> backend);

  std::string Name() const { return name_; }
  std::vector<ParameterInfo> ShortTermParameters() const;
  std::vector<ParameterInfo> LongTermParameters() const;
  Opaque PrepareMap(std::uint64_t map_seed) const;
  FlightRecord Fly(const FlightRequest& request, WorkerSlot& slot) const;
  ResolveRecord Resolve(const Opaque& query, const ParamValues& theta_s) const;

  /// The map of a given layout (e.g. a saved one, `quadtune fly --layout`), as PrepareMap makes
  /// the map of a generated one.
  [[nodiscard]] Opaque MapOf(layout::Layout layout) const;

  [[nodiscard]] const ClosedLoopOptions& options() const { return *options_; }
  [[nodiscard]] const planning::TrajectoryBackend& backend() const { return *backend_; }

  /// The parameter schema of every BackendPlanner: θ_s and θ_l with
  /// PlannerParams' ranges, integer flags and defaults; what a back end's registration gives.
  static PlannerSchema Schema();

 private:
  std::string name_;
  std::shared_ptr<const ClosedLoopOptions> options_;
  std::shared_ptr<const planning::TrajectoryBackend> backend_;
};

/// The project's Ipopt planner: a BackendPlanner named "ipopt" over a planning::IpoptBackend (the
/// minimum-jerk optimiser on the distance field, retries, stop-and-go fallback) that owns its
/// TrajectoryOptimizer, built from `options.flight.planner.optimizer`.
class IpoptPlanner : public BackendPlanner {
 public:
  explicit IpoptPlanner(ClosedLoopOptions options);
};

/// A planning::IpoptBackend that owns its TrajectoryOptimizer, built from `options` (the default:
/// sim::FlightOptions' optimiser settings, as IpoptPlanner flies by default).
[[nodiscard]] std::shared_ptr<const planning::TrajectoryBackend> MakeIpoptBackend(
    const planning::TrajectoryOptimizerOptions& options = sim::FlightOptions{}.planner.optimizer);

/// Settings of EgoPlanner: the closed loop's (its `flight.planner.optimizer`, the Ipopt back end's
/// solver settings, is unused) and the EGO back end's.
struct EgoPlannerOptions {
  ClosedLoopOptions common;
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

}  // namespace quadtune::engine
