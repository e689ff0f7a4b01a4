#include "quadtune/engine/planners.hpp"
#include "quadtune/planning/parameter_schema.hpp"

#include <bit>
#include <filesystem>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include "quadtune/common/random.hpp"
#include "quadtune/engine/experiment.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/trajectory_backend.hpp"

namespace quadtune::engine {

const char* ToString(EvalStatus status) {
  switch (status) {
    case EvalStatus::kOk: return "ok";
    case EvalStatus::kFailed: return "failed";
    case EvalStatus::kCancelled: return "cancelled";
  }
  return "?";
}

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

IpoptPlannerOptions IpoptPlannerOptions::FromYaml(const YamlMap& p, const std::string& base_dir,
                                                  const std::vector<std::string>& extra_keys) {
  std::vector<std::string> allowed{"type",     "drone", "layout", "layout_file", "world",
                                   "mission",  "max_time", "fixed", "safety_nets"};
  allowed.insert(allowed.end(), extra_keys.begin(), extra_keys.end());
  p.RejectUnknownKeys(allowed);
  IpoptPlannerOptions o;
  const std::string drone =
      ResolvePath(p.String("drone", std::string("drones/research_1kg.yaml")), base_dir);
  if (!std::filesystem::exists(drone)) {
    p.Fail("drone", "file '" + drone + "' not found (searched next to the experiment and in assets/)");
  }
  o.drone = physics::LoadDroneDescription(drone);
  if (p.Has("layout") && p.Has("layout_file")) p.Fail("layout_file", "give either layout or layout_file");
  if (p.Has("layout_file")) {
    const std::string lf = ResolvePath(p.String("layout_file"), base_dir);
    if (!std::filesystem::exists(lf)) p.Fail("layout_file", "file '" + lf + "' not found");
    o.layout = layout::LayoutOptions::LoadFile(lf);
  } else if (p.Has("layout")) {
    o.layout = layout::LayoutOptions::FromYaml(p.Map("layout"));
  } else {
    p.Fail("layout", "missing: give layout (generator options) or layout_file");
  }
  if (p.Has("world")) o.world = physics::WorldOptions::FromYaml(p.Map("world"));
  o.world.collision_response = physics::CollisionResponse::kPassThrough;
  o.mission = sim::MissionKindFromString(
      p.String("mission", std::string("go_and_return"), {"go_and_return", "go_to"}), p.file(),
      "planner.mission");
  o.flight.max_time = p.Number("max_time", 60.0, Range::Positive());
  if (p.Has("fixed")) o.base = planning::PlannerParams::FromYaml(p.Map("fixed"));
  if (!p.Bool("safety_nets", true)) {
    // Plan as the paper's planners do: one back-end attempt per re-plan, no collision-weight
    // escalation, no stop-and-go fallback (a failed re-plan is a failure, n_s = 1).
    if (p.Has("fixed") && p.Map("fixed").Has("max_attempts")) {
      p.Fail("safety_nets", "false sets max_attempts to 1; remove fixed.max_attempts");
    }
    o.base.max_attempts = 1;
    o.flight.planner.retry_collision_gain = 1.0;
    o.flight.replanner.fallback_speed = 0.0;
  }
  o.base.Validate(p.file());
  o.flight.planner.CheckParams(o.base, p.file());
  return o;
}

namespace {

struct IpoptMap {
  layout::Layout layout;
  std::shared_ptr<const physics::ObstacleGeometry> geometry;
};

Opaque PrepareLayoutMap(const IpoptPlannerOptions& o, std::uint64_t map_seed) {
  IpoptMap map;
  map.layout = layout::GenerateLayout(o.layout, map_seed);
  map.geometry = physics::ObstacleGeometry::Make(map.layout.obstacles, o.world);
  return Opaque::Make(std::move(map));
}

// One closed-loop flight of a planner built on sim::Fly with `backend`.
FlightRecord FlyWithBackend(const IpoptPlannerOptions& o, const planning::TrajectoryBackend& backend,
                            const FlightRequest& request, WorkerSlot& slot) {
  const IpoptMap& map = request.map.As<IpoptMap>();
  planning::PlannerParams params = o.base;
  for (const auto& [name, value] : request.params) params.Set(name, value);
  params.Validate("flight parameters");
  const sim::Scenario scenario =
      sim::Scenario::OverLayout(map.layout, o.mission, o.drone, o.world, request.seed, map.geometry);
  // World pool: the slot keeps its World; MakeWorld re-uses it (static objects rebuilt only when
  // the geometry differs).
  auto* world = std::any_cast<std::shared_ptr<physics::World>>(&slot.state);
  if (world == nullptr) {
    slot.state = std::shared_ptr<physics::World>();
    world = std::any_cast<std::shared_ptr<physics::World>>(&slot.state);
  }
  sim::MakeWorld(scenario, *world);
  ++slot.uses;

  sim::FlightHooks hooks;
  int queries = 0;
  if (request.short_params_provider) {
    hooks.params_provider = [&](double t, planning::PlannerParams& p) {
      ParamValues theta_s;
      for (const auto& n : planning::PlannerParams::ShortTermNames()) theta_s[n] = p.Get(n);
      request.short_params_provider(t, theta_s);
      for (const auto& [n, v] : theta_s) p.Set(n, v);
    };
  }
  if (request.on_query) {
    hooks.on_plan = [&](const planning::PlanningQuery& q, const planning::PlanOutcome&) {
      ++queries;
      request.on_query(Opaque::Make(q));
    };
  }
  hooks.cancelled = request.cancelled;
  sim::FlightOptions flight = o.flight;
  flight.log_rate_hz = 0.0;
  const sim::FlightResult result =
      sim::Fly(**world, scenario.mission, params, flight, backend, hooks);
  const auto& m = result.metrics;
  FlightRecord r;
  r.status = m.status == sim::FlightStatus::kError || m.status == sim::FlightStatus::kDiverged
                 ? EvalStatus::kFailed
                 : (m.status == sim::FlightStatus::kCancelled ? EvalStatus::kCancelled
                                                                   : EvalStatus::kOk);
  r.message = std::string(sim::ToString(m.status)) + (m.message.empty() ? "" : ": " + m.message);
  r.completed = m.status == sim::FlightStatus::kCompleted;
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

// A re-solve of a recorded query with `backend`.
ResolveRecord ResolveWithBackend(const planning::TrajectoryBackend& backend,
                                 const planning::LocalPlannerOptions& options,
                                 const Opaque& query, const ParamValues& theta_s) {
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

BackendPlanner::BackendPlanner(std::string name, IpoptPlannerOptions options,
                               std::shared_ptr<const planning::TrajectoryBackend> backend)
    : name_(std::move(name)),
      options_(std::make_shared<const IpoptPlannerOptions>(std::move(options))),
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
  return PrepareLayoutMap(*options_, map_seed);
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

IpoptPlanner::IpoptPlanner(IpoptPlannerOptions options)
    : BackendPlanner("ipopt", options, MakeIpoptBackend(options.flight.planner.optimizer)) {}

EgoPlanner::EgoPlanner(EgoPlannerOptions options)
    : BackendPlanner("ego", std::move(options.common),
                     std::make_shared<const planning::EgoBackend>(options.ego)),
      ego_(std::move(options.ego)) {}

// ---------------------------------------------------------------------------------------------
// ToyPlanner

namespace {

struct ToyMap {
  std::vector<double> gate_x;      // positions (m)
  std::vector<double> gate_limit;  // speed limits (m/s)
};

struct ToyQuery {
  double a = 1.0;  // problem coefficient in [0.5, 1.5]
  double x0 = 0.0;
};

struct ToySolve {
  bool ok = false;
  int iterations = 0;
  int failed = 0;
};

double Param(const ParamValues& v, const char* name, double fallback) {
  auto it = v.find(name);
  return it == v.end() ? fallback : it->second;
}

/// Damped fixed-point iteration for x = cos(a x); up to two attempts (second with half gain).
ToySolve ToySolveQuery(const ToyQuery& q, double gain, int max_iter) {
  ToySolve s;
  for (int attempt = 0; attempt < 2; ++attempt) {
    const double g = attempt == 0 ? gain : 0.5 * gain;
    double x = q.x0;
    for (int k = 0; k < max_iter; ++k) {
      ++s.iterations;
      const double next = x + g * (std::cos(q.a * x) - x);
      if (!std::isfinite(next)) break;
      if (std::abs(next - x) < 1e-9) {
        s.ok = true;
        return s;
      }
      x = next;
    }
    ++s.failed;
  }
  return s;
}

}  // namespace

ToyPlanner::ToyPlanner(ToyPlannerOptions options) : options_(options) {}

std::vector<ParameterInfo> ToyPlanner::ShortTermParameters() const {
  // Damping gains above 2 diverge on every query; more than 10 000 iterations is no budget.
  return {{"gain", 0.3, {0.0, 2.0, true, false}, false},
          {"max_iter", 20, Range::Closed(1, 10000), true}};
}
std::vector<ParameterInfo> ToyPlanner::LongTermParameters() const {
  return {{"speed", 2.0, {0.0, 100.0, true, false}, false},
          {"margin", 0.5, Range::Closed(0.0, 1000.0), false}};
}

Opaque ToyPlanner::PrepareMap(std::uint64_t map_seed) const {
  Rng rng(DeriveSeed(map_seed, {0x70f}));
  ToyMap map;
  for (int i = 0; i < options_.gates; ++i) {
    map.gate_x.push_back(options_.length * (i + 0.5 + 0.3 * (Uniform01(rng) - 0.5)) / options_.gates);
    map.gate_limit.push_back(Uniform(rng, options_.gate_speed_min, options_.gate_speed_max));
  }
  return Opaque::Make(std::move(map));
}

FlightRecord ToyPlanner::Fly(const FlightRequest& request, WorkerSlot& slot) const {
  const auto& map = request.map.As<ToyMap>();
  const auto t0 = std::chrono::steady_clock::now();
  if (options_.flight_delay_s > 0.0) {
    std::this_thread::sleep_for(std::chrono::duration<double>(options_.flight_delay_s));
  }
  ++slot.uses;
  const double speed = Param(request.params, "speed", 2.0);
  const double margin = Param(request.params, "margin", 0.5);
  if (!(speed > 0.0) || !(margin >= 0.0)) {
    throw ConfigError("flight parameters", "speed", "speed must be > 0 and margin >= 0");
  }
  if (options_.throw_speed_above > 0.0 && speed > options_.throw_speed_above) {
    throw std::runtime_error("toy planner: speed " + std::to_string(speed) + " above " +
                             std::to_string(options_.throw_speed_above));
  }
  Rng rng(request.seed);
  const double accel = 3.0;
  FlightRecord r;
  double t = 0.0;
  double x = 0.0;
  std::size_t next_gate = 0;
  ParamValues theta_s{{"gain", Param(request.params, "gain", 0.3)},
                      {"max_iter", Param(request.params, "max_iter", 20)}};
  while (x < options_.length) {
    if (request.cancelled && request.cancelled()) {
      r.status = EvalStatus::kCancelled;
      r.message = "cancelled";
      return r;
    }
    // One plan per interval.
    ToyQuery q;
    q.a = 0.5 + 0.5 * (1.0 + std::sin(0.7 * x + 0.3 * static_cast<double>(next_gate)));
    q.x0 = Uniform(rng, -1.0, 1.0);
    if (request.short_params_provider) request.short_params_provider(t, theta_s);
    const ToySolve s = ToySolveQuery(q, theta_s["gain"], static_cast<int>(std::lround(theta_s["max_iter"])));
    ++r.plans;
    r.failed_attempts += s.failed;
    r.compute_units += s.iterations;
    if (!s.ok) {
      ++r.failed_plans;
      t += 0.3;  // hover while re-planning
    }
    ++r.queries;
    if (request.on_query) request.on_query(Opaque::Make(q));
    const double step = std::min(options_.plan_interval, options_.length - x);
    // Gates inside this step.
    double v = speed * (1.0 + 0.02 * (Uniform01(rng) - 0.5));
    while (next_gate < map.gate_x.size() && map.gate_x[next_gate] <= x + step) {
      const double limit = map.gate_limit[next_gate];
      t += 0.5 * margin / v;  // looking further ahead slows the approach
      if (v > limit) {
        const double braking = (v * v - limit * limit) / (2.0 * accel);
        if (margin >= braking) {
          ++r.emergency_stops;
          t += 2.0 * (v - limit) / accel;
        } else {
          ++r.collisions;
        }
      }
      ++next_gate;
    }
    t += step / v;
    x += step;
    r.jerk_integral += v * v * 0.01;
  }
  r.completed = true;
  r.flight_time = t;
  r.min_clearance = 1.0 / (1.0 + r.collisions);
  r.message = "completed";
  r.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

ResolveRecord ToyPlanner::Resolve(const Opaque& query, const ParamValues& theta_s) const {
  const auto& q = query.As<ToyQuery>();
  const auto t0 = std::chrono::steady_clock::now();
  const double gain = Param(theta_s, "gain", 0.3);
  const int max_iter = static_cast<int>(std::lround(Param(theta_s, "max_iter", 20)));
  const ToySolve s = ToySolveQuery(q, gain, max_iter);
  ResolveRecord r;
  r.success = s.ok;
  r.attempts = s.failed + (s.ok ? 1 : 0);
  r.failed_attempts = s.failed;
  r.compute_units = s.iterations;
  r.duration = 1.0 + 0.01 * s.iterations;
  r.jerk_integral = gain * gain;
  r.min_clearance = 0.5 + 0.1 * gain;
  r.solve_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

// ---------------------------------------------------------------------------------------------
// SleepPlanner

namespace {

struct SleepMap {
  std::uint64_t seed = 0;
  std::vector<double> gate_limit;  // (m/s)
};

struct SleepQuery {
  std::uint64_t seed = 0;
  double difficulty = 1.0;  // the effort a re-solve needs to succeed
};

/// A log-normal draw with the given median and 95th percentile.
double LogNormal(Rng& rng, double median, double p95) {
  const double sigma = std::log(p95 / median) / 1.6448536269514722;
  return median * std::exp(sigma * StandardNormal(rng));
}

void SleepFor(double seconds) {
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
}

}  // namespace

SleepPlanner::SleepPlanner(SleepPlannerOptions options) : options_(options) {}

std::vector<ParameterInfo> SleepPlanner::ShortTermParameters() const { return {{"effort", 1.0}}; }
std::vector<ParameterInfo> SleepPlanner::LongTermParameters() const { return {{"pace", 1.0}}; }

Opaque SleepPlanner::PrepareMap(std::uint64_t map_seed) const {
  Rng rng(DeriveSeed(map_seed, {0x51ee}));
  SleepMap map;
  map.seed = map_seed;
  for (int i = 0; i < 5; ++i) map.gate_limit.push_back(Uniform(rng, 1.5, 3.0));
  return Opaque::Make(std::move(map));
}

FlightRecord SleepPlanner::Fly(const FlightRequest& request, WorkerSlot& slot) const {
  const auto& map = request.map.As<SleepMap>();
  const auto t0 = std::chrono::steady_clock::now();
  ++slot.uses;
  const double pace = Param(request.params, "pace", 1.0);
  if (!(pace > 0.0)) throw ConfigError("flight parameters", "pace", "pace must be > 0");
  Rng rng(DeriveSeed(request.seed, {map.seed}));
  const double wall = LogNormal(rng, options_.flight_median_s, options_.flight_p95_s);
  ParamValues theta_s{{"effort", Param(request.params, "effort", 1.0)}};
  FlightRecord r;
  for (int q = 0; q < options_.queries_per_flight; ++q) {
    if (request.cancelled && request.cancelled()) {
      r.status = EvalStatus::kCancelled;
      r.message = "cancelled";
      return r;
    }
    if (request.short_params_provider) {
      request.short_params_provider(20.0 * q / (pace * options_.queries_per_flight), theta_s);
    }
    SleepQuery query;
    query.seed = rng();
    query.difficulty = Uniform(rng, 0.5, 1.5);
    ++r.plans;
    ++r.queries;
    if (theta_s["effort"] < query.difficulty) {
      ++r.failed_plans;
      ++r.failed_attempts;
    }
    r.compute_units += 10.0;
    if (request.on_query) request.on_query(Opaque::Make(query));
    SleepFor(wall / options_.queries_per_flight);
  }
  for (const double limit : map.gate_limit) {
    if (pace > limit) ++r.collisions;
  }
  r.completed = true;
  r.flight_time = 20.0 / pace;
  r.jerk_integral = pace * pace;
  r.min_clearance = 1.0 / (1.0 + r.collisions);
  r.message = "completed";
  r.wall_time = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

ResolveRecord SleepPlanner::Resolve(const Opaque& query, const ParamValues& theta_s) const {
  const auto& q = query.As<SleepQuery>();
  const auto t0 = std::chrono::steady_clock::now();
  const double effort = Param(theta_s, "effort", 1.0);
  if (!(effort > 0.0)) throw ConfigError("re-solve parameters", "effort", "effort must be > 0");
  Rng rng(DeriveSeed(q.seed, {std::bit_cast<std::uint64_t>(effort)}));
  const double cost = LogNormal(rng, options_.resolve_median_s, options_.resolve_p95_s) *
                      (0.5 + 0.25 * (effort + 1.0 / effort));
  SleepFor(cost);
  ResolveRecord r;
  r.success = effort >= q.difficulty;
  r.attempts = 1;
  r.failed_attempts = r.success ? 0 : 1;
  r.compute_units = cost / 1e-4;
  r.duration = 1.0;
  r.jerk_integral = effort;
  r.min_clearance = 0.5;
  r.solve_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace quadtune::engine
