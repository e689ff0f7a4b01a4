#pragma once
/// \file
/// Planner plug-ins for tests, outside the production library (library
/// `quadtune_test_planners`, target `quadtune::test_planners`):
///
/// - ToyPlanner (`planner.type: toy`): a deliberately simple 1-D planner (a point moving along a
///   line through gates) with its own parameter names, to show that the engine tunes any plug-in
///   and to run the tuner in milliseconds. θ_s = {gain, max_iter}, θ_l = {speed, margin}.
/// - SleepPlanner (`planner.type: sleep`): a scale model of IpoptPlanner's cost for distributed
///   runs: flights and re-solves sleep for seeded log-normal durations (no core used), so that
///   many ranks on a few cores load rank 0 as that many cores would. θ_s = {effort}, θ_l = {pace}.
///
/// Both register through the public registry (engine::PlannerRegistration in toy_planners.cpp),
/// as a planner of one's own does; a program sees `toy` and `sleep` when it links
/// quadtune::test_planners (the whole archive: CMake's WHOLE_ARCHIVE link feature). The test
/// program `quadtune_test_cli` is the `quadtune` program with them linked in.
///
/// Thread safety: both are immutable after construction; all members are safe to call
/// concurrently on distinct WorkerSlots.

#include <cstdint>
#include <string>
#include <vector>

#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/api/planner.hpp"

namespace quadtune::engine::test {

/// Settings of ToyPlanner (the experiment file's `planner.toy` map).
struct ToyPlannerOptions {
  double length = 20.0;         ///< track length (m), > 0
  int gates = 6;                ///< gates along the track, >= 0; each has a random speed limit
  double gate_speed_min = 2.0;  ///< gate speed limits are uniform in [min, max] (m/s)
  double gate_speed_max = 4.0;
  double plan_interval = 1.0;   ///< a planning query every this many metres (m), > 0
  double flight_delay_s = 0.0;  ///< wall-clock sleep per flight (s), to simulate cost in tests
  /// Fly() throws std::runtime_error when θ_l's speed exceeds this (m/s); <= 0: never.
  double throw_speed_above = 0.0;

  /// Reads the `planner:` map of an experiment file (keys `type` and `toy`); throws ConfigError
  /// naming the key for unknown keys and values out of range.
  static ToyPlannerOptions FromYaml(const YamlMap& planner);
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

  /// Reads the `planner:` map of an experiment file (keys `type` and `sleep`); throws
  /// ConfigError naming the key for unknown keys and values out of range.
  static SleepPlannerOptions FromYaml(const YamlMap& planner);
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

}  // namespace quadtune::engine::test
