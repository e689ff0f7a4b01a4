#include "quadtune/engine/planners/planners.hpp"

#include <bit>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <stdexcept>
#include <thread>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/engine/api/asset_paths.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/physics/depth_sensor.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/parameter_schema.hpp"
#include "quadtune/planning/trajectory_backend.hpp"

namespace quadtune::engine {

ParamValues Planner::Defaults() const {
  ParamValues values;
  for (const auto& p : ShortTermParameters()) values[p.name] = p.default_value;
  for (const auto& p : LongTermParameters()) values[p.name] = p.default_value;
  return values;
}

// ---------------------------------------------------------------------------------------------
// The closed loop's options and parameters (IpoptPlanner, EgoPlanner, BackendPlanner)

std::vector<ParameterInfo> PlannerParamsInfo(const planning::PlannerParams& values,
                                             const std::vector<std::string>& names) {
  std::vector<ParameterInfo> out;
  for (const auto& n : names) {
    out.push_back({n, values.Get(n), planning::ParameterRange(n), planning::ParameterIsInteger(n)});
  }
  return out;
}

namespace {

constexpr double kDefaultMaxTime = 60.0;  // planner.max_time (s)

// `key` of `p`, resolved against `base_dir`; it must exist.
std::string ExistingFile(const YamlMap& p, const std::string& key, const std::string& base_dir,
                         const std::string& where) {
  const std::string path = ResolvePath(p.String(key), base_dir);
  p.CheckFile(key, path, where);
  return path;
}

void WriteText(YAML::Emitter& out, const char* key, const std::string& value) {
  out << YAML::Key << key << YAML::Value << value;
}

/// `planner.layout`: exactly one of `layout` and `layout_file` is given.
void ReadLayout(const YamlMap& p, ClosedLoopSection& s) {
  if (p.Has("layout") && p.Has("layout_file")) {
    p.Fail("layout_file", "give either layout or layout_file");
  }
  if (!p.Has("layout") && !p.Has("layout_file")) {
    p.Fail("layout", "missing: give layout (generator options) or layout_file");
  }
  if (p.Has("layout")) {
    s.layout_file.clear();
    s.options.layout = layout::LayoutOptions::FromYaml(p.Map("layout"));
  }
}

void WriteLayout(YAML::Emitter& out, const ClosedLoopSection& s) {
  if (!s.layout_file.empty()) return;
  out << YAML::Key << "layout" << YAML::Value;
  s.options.layout.ToYaml(out);
}

// The closed loop's sensor and goal rule (keys of the planner section).
Fields<ClosedLoopSection> AddClosedLoopKeys(Fields<ClosedLoopSection> f) {
  using S = ClosedLoopSection;
  const auto unwritten = [](YAML::Emitter&, const S&) {};
  f.Custom(
       {"sensor", "map", "48 x 32 pixels, 87° x 58°, 15 Hz, 5 m",
        "[depth sensor](#depth-sensor) keys",
        "ipopt: the depth camera; keys not given keep the default's (EGO-Planner's "
        "simulator: `{horizontal_fov_deg: 120, rate_hz: 12}`)"},
       [](const YamlMap& p, S& s) {
         if (!p.Has("sensor")) return;
         physics::DepthSensorFields().Read(p.Map("sensor"), s.options.flight.sensor);
         s.options.flight.sensor.Validate(p.file());
       },
       unwritten)
      .Custom(
          {"goal_braking", "bool", "false", "",
           "ipopt: `true` gives a horizon goal within stopping distance d of the mission "
           "goal the terminal speed min(v_des, √(2 a_max d)) (EGO-Planner's local-target "
           "rule), so a fast drone can stop at the goal; `false`: v_des at every horizon goal"},
          [](const YamlMap& p, S& s) {
            s.options.flight.planner.goal_braking =
                p.Bool("goal_braking", s.options.flight.planner.goal_braking);
          },
          [](YAML::Emitter& out, const S& s) {
            if (s.options.flight.planner.goal_braking)
              out << YAML::Key << "goal_braking" << YAML::Value << true;
          })
      .Custom(
          {"max_time", "number", FormatNumber(kDefaultMaxTime), DescribeInterval(Range::Positive()),
           "ipopt: flight time limit; a flight past it fails (s)"},
          [](const YamlMap& p, S& s) {
            s.options.flight.max_time = p.Number("max_time", kDefaultMaxTime, Range::Positive());
          },
          [](YAML::Emitter& out, const S& s) {
            out << YAML::Key << "max_time" << YAML::Value << s.options.flight.max_time;
          });
  return f;
}

/// The keys of one back end only (ignored by the others).
Fields<ClosedLoopSection> AddBackendKeys(Fields<ClosedLoopSection> f) {
  using S = ClosedLoopSection;
  f.Custom(
      {"ego_stop_and_go", "bool", "false", "",
       "ego: a re-plan from rest whose every attempt failed flies the front end's path "
       "stop-and-go, judged by the back end's check (the ipopt planner always does, unless "
       "`safety_nets` is false)"},
      [](const YamlMap& p, S& s) {
        s.options.ego_stop_and_go = p.Bool("ego_stop_and_go", s.options.ego_stop_and_go);
      },
      [](YAML::Emitter& out, const S& s) {
        if (s.options.ego_stop_and_go) out << YAML::Key << "ego_stop_and_go" << YAML::Value << true;
      });
  return f;
}

}  // namespace

const Fields<ClosedLoopSection>& ClosedLoopFields() {
  using S = ClosedLoopSection;
  // world and fixed are written by nothing here: WorldOptions and PlannerParams have no writer.
  const auto unwritten = [](YAML::Emitter&, const S&) {};
  static const Fields<S> fields =
      AddBackendKeys(AddClosedLoopKeys(Fields<S>()))
          .Custom(
              {"type", "string", "`ipopt`",
               "a registered type: `ipopt`, `ego`, or one a program registers "
               "([own-planner.md](own-planner.md))",
               "`ipopt`: the full stack; `ego`: the EGO-Planner-style back end in the same "
               "closed loop. The test program `quadtune_test_cli` also has the test planners "
               "`toy` (a cheap 1-D plug-in) and `sleep` (a scale model of the Ipopt "
               "planner's wall times), [testing.md](testing.md#test-planners-and-the-test-"
               "program)"},
              [](const YamlMap& p, S& s) { s.type = p.String("type", s.type); },
              [](YAML::Emitter& out, const S& s) { WriteText(out, "type", s.type); })
          .Custom(
              {"drone", "path", "`drones/research_1kg.yaml`", "an existing [drone](#drone) file",
               "ipopt: the drone flown"},
              [](const YamlMap& p, S& s) {
                s.drone = p.String("drone", s.drone);
                const std::string drone = ResolvePath(s.drone, s.base_dir);
                p.CheckFile("drone", drone, " (searched next to the experiment and in assets/)");
                s.options.drone = physics::LoadDroneDescription(drone);
              },
              [](YAML::Emitter& out, const S& s) { WriteText(out, "drone", s.drone); })
          .Custom({"layout", "map", "one of `layout`, `layout_file` required",
                   "[layout options](#layout)",
                   "ipopt: the forest; give exactly one of `layout`, `layout_file`"},
                  ReadLayout, WriteLayout)
          .Custom(
              {"layout_file", "path", "one of `layout`, `layout_file` required",
               "a [layout options](#layout) file", "ipopt: the forest, from a file"},
              [](const YamlMap& p, S& s) {
                if (!p.Has("layout_file")) return;
                s.layout_file = p.String("layout_file");
                s.options.layout =
                    layout::LayoutOptions::LoadFile(ExistingFile(p, "layout_file", s.base_dir, ""));
              },
              [](YAML::Emitter& out, const S& s) {
                if (!s.layout_file.empty()) WriteText(out, "layout_file", s.layout_file);
              })
          .Custom(
              {"world", "map", "ideal world", "[world options](#world)",
               "ipopt: the world's seed is set per flight; collisions are always "
               "pass-through (counted, not stopping the drone)"},
              [](const YamlMap& p, S& s) {
                if (p.Has("world"))
                  s.options.world = physics::WorldOptions::FromYaml(p.Map("world"));
                s.options.world.collision_response = physics::CollisionResponse::kPassThrough;
              },
              unwritten)
          .Custom(
              {"mission", "string", "`go_and_return`", "`go_and_return`, `go_to`",
               "ipopt: the mission over the layout's start and goal"},
              [](const YamlMap& p, S& s) {
                s.options.mission = ReadEnum<sim::MissionKind>(p, "mission", s.options.mission);
              },
              [](YAML::Emitter& out, const S& s) {
                WriteText(out, "mission", sim::ToString(s.options.mission));
              })
          .Custom(
              {"fixed", "map", "planner defaults", "[planner parameters](#planner-parameters)",
               "ipopt: values of parameters not tuned"},
              [](const YamlMap& p, S& s) {
                if (p.Has("fixed"))
                  s.options.base = planning::PlannerParams::FromYaml(p.Map("fixed"));
              },
              unwritten)
          .Custom(
              {"safety_nets", "bool", "true", "",
               "ipopt: `false` plans as the paper's planners do: one back-end attempt per "
               "re-plan (`max_attempts` 1; `fixed.max_attempts` is then refused), no 10× "
               "collision-weight retries, no stop-and-go fallback"},
              [](const YamlMap& p, S& s) {
                s.safety_nets = p.Bool("safety_nets", s.safety_nets);
                if (s.safety_nets) return;
                // Plan as the paper's planners do: one back-end attempt per re-plan, no
                // collision-weight escalation, no stop-and-go fallback (a failed re-plan is a
                // failure, n_s = 1).
                if (p.Has("fixed") && p.Map("fixed").Has("max_attempts")) {
                  p.Fail("safety_nets", "false sets max_attempts to 1; remove fixed.max_attempts");
                }
                s.options.base.max_attempts = 1;
                s.options.flight.planner.retry_collision_gain = 1.0;
                s.options.flight.replanner.fallback_speed = 0.0;
              },
              [](YAML::Emitter& out, const S& s) {
                out << YAML::Key << "safety_nets" << YAML::Value << s.safety_nets;
              });
  return fields;
}

ClosedLoopOptions ClosedLoopOptions::FromYaml(const YamlMap& p, const std::string& base_dir,
                                                  const std::vector<std::string>& extra_keys) {
  std::vector<std::string> allowed = ClosedLoopFields().Keys();
  allowed.insert(allowed.end(), extra_keys.begin(), extra_keys.end());
  p.RejectUnknownKeys(allowed);
  // The caller's own keys, removed from a copy, so that the field list sees only its keys.
  YAML::Node own = YAML::Clone(p.node());
  if (own.IsMap()) {
    for (const auto& key : extra_keys) own.remove(key);
  }
  ClosedLoopSection s;
  s.base_dir = base_dir;
  ClosedLoopFields().Read(YamlMap(own, p.file(), p.path()), s);
  s.options.base.Validate(p.file());
  s.options.flight.planner.CheckParams(s.options.base, p.file());
  return s.options;
}

namespace {

struct IpoptMap {
  layout::Layout layout;
  std::shared_ptr<const physics::ObstacleGeometry> geometry;
};

Opaque LayoutMap(const ClosedLoopOptions& o, layout::Layout layout) {
  IpoptMap map;
  map.layout = std::move(layout);
  map.geometry = physics::ObstacleGeometry::Make(map.layout.obstacles, o.world);
  return Opaque::Make(std::move(map));
}

/// The slot's state of a closed-loop planner: its World, kept between flights.
struct ClosedLoopSlot {
  std::shared_ptr<physics::World> world;
};

/// A flight's end as the stored state names it (kOk for a completed flight).
EvalState FlightEnding(sim::FlightStatus status) {
  switch (status) {
    case sim::FlightStatus::kCompleted:
      return EvalState::kOk;
    case sim::FlightStatus::kTimeout:
      return EvalState::kTimeout;
    case sim::FlightStatus::kStalled:
      return EvalState::kStalled;
    case sim::FlightStatus::kDiverged:
      return EvalState::kDiverged;
    case sim::FlightStatus::kError:
      return EvalState::kError;
    case sim::FlightStatus::kCancelled:
      return EvalState::kCancelled;
  }
  return EvalState::kError;
}

/// The record of a flight with these metrics and `queries` reported queries.
FlightRecord RecordOf(const sim::FlightMetrics& m, int queries) {
  FlightRecord r;
  r.status =
      m.status == sim::FlightStatus::kError || m.status == sim::FlightStatus::kDiverged
          ? EvalStatus::kFailed
          : (m.status == sim::FlightStatus::kCancelled ? EvalStatus::kCancelled : EvalStatus::kOk);
  r.message = std::string(sim::ToString(m.status)) + (m.message.empty() ? "" : ": " + m.message);
  r.completed = m.status == sim::FlightStatus::kCompleted;
  r.ending = FlightEnding(m.status);
  r.flight_time = m.flight_time;
  r.collisions = m.collisions;
  r.emergency_stops = m.emergency_stops;
  r.plans = m.plans;
  r.failed_plans = m.failed_plans;
  r.fallback_plans = m.fallback_plans;
  r.failed_attempts = m.failed_attempts;
  r.compute_units = m.compute_units;
  r.jerk_integral = m.jerk_integral;
  r.min_clearance = m.min_clearance;
  r.wall_time = m.wall_time;
  r.queries = queries;
  return r;
}

std::vector<double> Point(const Eigen::Vector3d& p) { return {p.x(), p.y(), p.z()}; }

/// The achieved value of what the layout's spacing means: the mean free gap (zones weighted by
/// their obstacle counts) under `free_gap`, else the mean nearest-neighbour centre distance.
double AchievedSpacing(const layout::Layout& layout) {
  if (layout.options.density != layout::DensityDefinition::kFreeGap) {
    return layout.stats.overall.mean;
  }
  double sum = 0.0;
  double count = 0.0;
  for (const auto& z : layout.stats.zones) {
    sum += z.gap.mean * static_cast<double>(z.gap.count);
    count += static_cast<double>(z.gap.count);
  }
  return count > 0.0 ? sum / count : 0.0;
}

/// The closed loop's log: flight.csv, plans.csv, plan_steps.csv, obstacles.json and layout.yaml
/// in `directory`, and the summary facts of the flight and its map.
LogFacts WriteClosedLoopLog(const std::string& directory, const sim::FlightResult& result,
                            const layout::Layout& layout, const sim::Mission& mission,
                            const std::string& drone) {
  sim::WriteFlightLog(directory, result, layout.obstacles);
  layout.Save((std::filesystem::path(directory) / "layout.yaml").string());
  const sim::FlightMetrics& m = result.metrics;
  using I = std::int64_t;
  return {{"status", std::string(sim::ToString(m.status))},
          {"message", m.message},
          {"max_tracking_error", m.max_tracking_error},
          {"mean_tracking_error", m.mean_tracking_error},
          {"mean_solve_time", m.mean_solve_time},
          {"max_solve_time", m.max_solve_time},
          {"distance", m.distance},
          {"mean_speed", m.mean_speed},
          {"max_speed", m.max_speed},
          {"start", Point(mission.start_W)},
          {"goal", Point(mission.waypoints_W.front())},
          {"obstacles", static_cast<I>(layout.obstacles.size())},
          {"drone", drone},
          {"spacing_target", layout.options.spacing},
          {"density_definition", std::string(quadtune::ToString(layout.options.density))},
          {"spacing_achieved", AchievedSpacing(layout)}};
}

/// The flight's hooks into `request`: θ_s from its provider, each query counted into `queries`
/// and handed to its on_query, its cancel test.
sim::FlightHooks HooksOf(const FlightRequest& request, int& queries) {
  sim::FlightHooks hooks;
  if (request.short_params_provider) {
    hooks.params_provider = [&request](double t, planning::PlannerParams& p) {
      ParamValues theta_s;
      for (const auto& n : planning::PlannerParams::ShortTermNames()) theta_s[n] = p.Get(n);
      request.short_params_provider(t, theta_s);
      for (const auto& [n, v] : theta_s) p.Set(n, v);
    };
  }
  if (request.on_query) {
    hooks.on_plan = [&request, &queries](const planning::PlanningQuery& q,
                                         const planning::PlanOutcome&) {
      ++queries;
      request.on_query(Opaque::Make(q));
    };
  }
  hooks.cancelled = request.cancelled;
  return hooks;
}

// One closed-loop flight of a planner built on sim::Fly with `backend`.
FlightRecord FlyWithBackend(const ClosedLoopOptions& o,
                            const planning::TrajectoryBackend& backend,
                            const FlightRequest& request, WorkerSlot& slot) {
  const IpoptMap& map = request.map.As<IpoptMap>();
  planning::PlannerParams params = o.base;
  for (const auto& [name, value] : request.params) params.Set(name, value);
  params.Validate("flight parameters");
  const sim::Scenario scenario = sim::Scenario::OverLayout(map.layout, o.mission, o.drone, o.world,
                                                           request.seed, map.geometry);
  // World pool: the slot keeps its World; MakeWorld re-uses it (static objects rebuilt only when
  // the geometry differs).
  std::shared_ptr<physics::World>& world = slot.State<ClosedLoopSlot>().world;
  sim::MakeWorld(scenario, world);
  ++slot.uses;

  int queries = 0;
  const sim::FlightHooks hooks = HooksOf(request, queries);
  const bool log = !request.log_directory.empty();
  sim::FlightOptions flight = o.flight;
  // The state log is kept only for a flight's log; it does not change the flight.
  flight.log_rate_hz = log ? sim::FlightOptions{}.log_rate_hz : 0.0;
  const sim::FlightResult result =
      sim::Fly(*world, scenario.mission, params, flight, backend, hooks);
  FlightRecord r = RecordOf(result.metrics, queries);
  if (log && result.metrics.status != sim::FlightStatus::kCancelled) {
    r.log = WriteClosedLoopLog(request.log_directory, result, map.layout, scenario.mission,
                               o.drone.name);
    r.logged = true;
  }
  return r;
}

// A re-solve of a recorded query with `backend`.
ResolveRecord ResolveWithBackend(const planning::TrajectoryBackend& backend,
                                 const planning::LocalPlannerOptions& options, const Opaque& query,
                                 const ParamValues& theta_s) {
  const auto& q = query.As<planning::PlanningQuery>();
  planning::PlannerParams params = q.params;
  for (const auto& [name, value] : theta_s) params.Set(name, value);
  params.Validate("short-term parameters");
  const planning::PlanOutcome out = backend.Solve(q, params, options);
  ResolveRecord r;
  r.success = out.Ok();
  r.message = out.Ok() ? "" : out.result.message;
  r.attempts = out.attempts;
  r.failed_attempts = out.failed_attempts;
  r.solve_time_s = out.solve_time_s;
  r.compute_units = out.compute_units;
  r.duration = out.result.duration;
  r.jerk_integral = out.result.cost.jerk;
  r.min_clearance = out.result.min_clearance;
  return r;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// BackendPlanner, EgoPlanner

BackendPlanner::BackendPlanner(std::string name, ClosedLoopOptions options,
                               std::shared_ptr<const planning::TrajectoryBackend> backend)
    : name_(std::move(name)),
      options_(std::make_shared<const ClosedLoopOptions>(std::move(options))),
      backend_(std::move(backend)) {
  QT_DEMAND(backend_ != nullptr, "BackendPlanner: null back end");
}

PlannerSchema BackendPlanner::Schema() {
  const planning::PlannerParams defaults;
  return {PlannerParamsInfo(defaults, planning::PlannerParams::ShortTermNames()),
          PlannerParamsInfo(defaults, planning::PlannerParams::LongTermNames())};
}

std::vector<ParameterInfo> BackendPlanner::ShortTermParameters() const {
  return PlannerParamsInfo(options_->base, planning::PlannerParams::ShortTermNames());
}

std::vector<ParameterInfo> BackendPlanner::LongTermParameters() const {
  return PlannerParamsInfo(options_->base, planning::PlannerParams::LongTermNames());
}

Opaque BackendPlanner::PrepareMap(std::uint64_t map_seed) const {
  return LayoutMap(*options_, layout::GenerateLayout(options_->layout, map_seed));
}

Opaque BackendPlanner::MapOf(layout::Layout layout) const {
  return LayoutMap(*options_, std::move(layout));
}

FlightRecord BackendPlanner::Fly(const FlightRequest& request, WorkerSlot& slot) const {
  return FlyWithBackend(*options_, *backend_, request, slot);
}

ResolveRecord BackendPlanner::Resolve(const Opaque& query, const ParamValues& theta_s) const {
  return ResolveWithBackend(*backend_, options_->flight.planner, query, theta_s);
}

namespace {

/// planning::IpoptBackend together with the optimiser it refers to.
class OwningIpoptBackend final : public planning::TrajectoryBackend {
 public:
  explicit OwningIpoptBackend(const planning::TrajectoryOptimizerOptions& options)
      : optimizer_(options), backend_(optimizer_) {}

  std::string Name() const override { return backend_.Name(); }
  planning::QuerySnapshot Snapshot() const override { return backend_.Snapshot(); }
  planning::PlanOutcome Solve(const planning::PlanningQuery& query,
                              const planning::PlannerParams& params,
                              const planning::LocalPlannerOptions& options) const override {
    return backend_.Solve(query, params, options);
  }
  std::optional<planning::PlanResult> Fallback(const planning::PlanningQuery& query,
                                               const planning::PlannerParams& params,
                                               double speed) const override {
    return backend_.Fallback(query, params, speed);
  }

 private:
  planning::TrajectoryOptimizer optimizer_;  // before backend_, which refers to it
  planning::IpoptBackend backend_;
};

}  // namespace

std::shared_ptr<const planning::TrajectoryBackend> MakeIpoptBackend(
    const planning::TrajectoryOptimizerOptions& options) {
  return std::make_shared<const OwningIpoptBackend>(options);
}

IpoptPlanner::IpoptPlanner(ClosedLoopOptions options)
    : BackendPlanner("ipopt", options, MakeIpoptBackend(options.flight.planner.optimizer)) {}

EgoPlanner::EgoPlanner(EgoPlannerOptions options)
    : BackendPlanner("ego", std::move(options.common),
                     std::make_shared<const planning::EgoBackend>(options.ego)),
      ego_(std::move(options.ego)) {}

}  // namespace quadtune::engine
