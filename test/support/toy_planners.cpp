#include "toy_planners.hpp"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "quadtune/common/error.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/engine/api/planner_registry.hpp"

namespace quadtune::engine::test {

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
    map.gate_x.push_back(options_.length * (i + 0.5 + 0.3 * (Uniform01(rng) - 0.5)) /
                         options_.gates);
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
    const ToySolve s =
        ToySolveQuery(q, theta_s["gain"], static_cast<int>(std::lround(theta_s["max_iter"])));
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

// ---------------------------------------------------------------------------------------------
// Their experiment-file keys and their registration

ToyPlannerOptions ToyPlannerOptions::FromYaml(const YamlMap& p) {
  p.RejectUnknownKeys({"type", "toy"});
  const YamlMap t = p.Map("toy", true);
  t.RejectUnknownKeys({"length", "gates", "gate_speed_min", "gate_speed_max", "plan_interval",
                       "flight_delay_s", "throw_speed_above"});
  ToyPlannerOptions o;
  o.length = t.Number("length", o.length, Range::Positive());
  o.gates = static_cast<int>(t.Integer("gates", o.gates, Range::Closed(0, 1000)));
  o.gate_speed_min = t.Number("gate_speed_min", o.gate_speed_min, Range::Positive());
  o.gate_speed_max = t.Number("gate_speed_max", o.gate_speed_max, Range::Positive());
  if (o.gate_speed_max < o.gate_speed_min) t.Fail("gate_speed_max", "must be >= gate_speed_min");
  o.plan_interval = t.Number("plan_interval", o.plan_interval, Range::Positive());
  o.flight_delay_s = t.Number("flight_delay_s", o.flight_delay_s, Range::Closed(0.0, 10.0));
  o.throw_speed_above = t.Number("throw_speed_above", o.throw_speed_above, Range::Any());
  return o;
}

SleepPlannerOptions SleepPlannerOptions::FromYaml(const YamlMap& p) {
  p.RejectUnknownKeys({"type", "sleep"});
  const YamlMap t = p.Map("sleep", true);
  t.RejectUnknownKeys({"resolve_median_s", "resolve_p95_s", "flight_median_s", "flight_p95_s",
                       "queries_per_flight"});
  SleepPlannerOptions o;
  o.resolve_median_s = t.Number("resolve_median_s", o.resolve_median_s, Range::Closed(1e-6, 10.0));
  o.resolve_p95_s = t.Number("resolve_p95_s", o.resolve_p95_s, Range::Closed(1e-6, 10.0));
  o.flight_median_s = t.Number("flight_median_s", o.flight_median_s, Range::Closed(1e-6, 60.0));
  o.flight_p95_s = t.Number("flight_p95_s", o.flight_p95_s, Range::Closed(1e-6, 60.0));
  o.queries_per_flight = static_cast<int>(
      t.Integer("queries_per_flight", o.queries_per_flight, Range::Closed(1, 1e5)));
  if (o.resolve_p95_s < o.resolve_median_s) t.Fail("resolve_p95_s", "must be >= resolve_median_s");
  if (o.flight_p95_s < o.flight_median_s) t.Fail("flight_p95_s", "must be >= flight_median_s");
  return o;
}

namespace {

const PlannerRegistration kToy(
    "toy",
    [](const YamlMap& planner, const std::string& /*base_dir*/) {
      return Planner{ToyPlanner{ToyPlannerOptions::FromYaml(planner)}};
    },
    PlannerSchema::Of(ToyPlanner{}));

const PlannerRegistration kSleep(
    "sleep",
    [](const YamlMap& planner, const std::string& /*base_dir*/) {
      return Planner{SleepPlanner{SleepPlannerOptions::FromYaml(planner)}};
    },
    PlannerSchema::Of(SleepPlanner{}));

}  // namespace

}  // namespace quadtune::engine::test
