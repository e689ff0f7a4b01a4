// The corridor study of the changing-environment experiment. See corridor_study.hpp.
//
// Thread safety: RunCorridors calls the progress callback under its own lock; the rest is pure.
#include "quadtune/engine/adaptation/corridor_study.hpp"

#include <algorithm>
#include <limits>
#include <map>
#include <mutex>

#include "quadtune/common/cancel.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/common/parallel_for.hpp"

namespace quadtune::engine {

int ZoneIndex(const layout::LayoutOptions& options, double x) {
  const auto& zones = options.zones;
  for (std::size_t i = 0; i < zones.size(); ++i) {
    const bool last = i + 1 == zones.size();
    if (x >= zones[i].x_min && (x < zones[i].x_max || (last && x <= zones[i].x_max))) {
      return static_cast<int>(i);
    }
  }
  return -1;
}

std::pair<double, double> DenseSparseVDes(const sim::FlightResult& flight,
                                          const layout::LayoutOptions& options,
                                          double dense_below) {
  double sum[2] = {0.0, 0.0};
  double time[2] = {0.0, 0.0};
  const auto& log = flight.log;
  for (std::size_t i = 0; i + 1 < log.size(); ++i) {
    const int z = ZoneIndex(options, log[i].p_W.x());
    if (z < 0) continue;
    const int k = options.zones[static_cast<std::size_t>(z)].spacing < dense_below ? 0 : 1;
    const double dt = log[i + 1].t - log[i].t;
    sum[k] += log[i].v_des * dt;
    time[k] += dt;
  }
  return {time[0] > 0.0 ? sum[0] / time[0] : 0.0, time[1] > 0.0 ? sum[1] / time[1] : 0.0};
}

double CorridorFl(const sim::FlightMetrics& m, const AdaptExperiment& e) {
  if (m.status != sim::FlightStatus::kCompleted) return e.failure_value;
  return m.flight_time + m.flight_time * m.collisions + e.w_e * m.emergency_stops;
}

std::vector<FlightPolicy> CorridorPolicies(const AdaptExperiment& e) {
  std::vector<FlightPolicy> policies{FlightPolicy{}};
  if (e.adaptation.policy && e.adaptation.mode != AdaptationMode::kContext) {
    policies.push_back(FlightPolicy{std::nullopt, AdaptationMode::kContext});
  }
  for (double v : e.baselines) policies.push_back(FlightPolicy{v, std::nullopt});
  return policies;
}

std::vector<CorridorFlight> RunCorridors(
    const AdaptExperiment& e, const CorridorOptions& options,
    const std::function<void(const CorridorFlight&, int, int)>& progress,
    const std::atomic<bool>* cancel) {
  const std::vector<FlightPolicy> policies = CorridorPolicies(e);
  const int total = options.count * static_cast<int>(policies.size());
  std::vector<CorridorFlight> rows(static_cast<std::size_t>(total));
  // Each corridor's experiment (its seeds) and layout, made once for all its policies.
  std::vector<AdaptExperiment> experiments(static_cast<std::size_t>(options.count), e);
  std::vector<layout::Layout> layouts(experiments.size());
  ParallelFor(std::max(1, options.threads), std::size_t{0}, experiments.size(), [&](std::size_t c) {
    experiments[c].SetSeed(options.first_seed + c);
    layouts[c] = layout::GenerateLayout(experiments[c].layout, experiments[c].seed);
  });
  std::mutex mutex;
  int done = 0;
  ParallelFor(std::max(1, options.threads), 0, total, [&](int index) {
    if (cancel != nullptr && cancel->load()) return;
    const std::size_t corridor = static_cast<std::size_t>(index) / policies.size();
    const FlightPolicy& policy = policies[static_cast<std::size_t>(index) % policies.size()];
    const AdaptExperiment& ex = experiments[corridor];
    const layout::Layout& layout = layouts[corridor];
    const AdaptFlight flight = RunAdaptFlight(ex, layout, policy, {}, cancel);
    const sim::FlightMetrics& m = flight.result.metrics;
    CorridorFlight& row = rows[static_cast<std::size_t>(index)];
    row.corridor_seed = ex.seed;
    row.policy = flight.label;
    row.status = sim::ToString(m.status);
    row.f_l = CorridorFl(m, ex);
    row.flight_time = m.flight_time;
    row.collisions = m.collisions;
    row.emergency_stops = m.emergency_stops;
    row.mean_speed = m.mean_speed;
    std::tie(row.v_des_dense, row.v_des_sparse) =
        DenseSparseVDes(flight.result, layout.options, ex.dense_below);
    row.segments = static_cast<int>(flight.segments.size());
    const std::lock_guard<std::mutex> lock(mutex);
    ++done;
    if (progress) progress(row, done, total);
  });
  if (cancel != nullptr && cancel->load()) throw Cancelled("corridor study cancelled");
  return rows;
}

CorridorComparison CompareCorridors(const std::vector<CorridorFlight>& rows) {
  CorridorComparison out;
  std::vector<std::uint64_t> seeds;
  std::map<std::string, std::map<std::uint64_t, const CorridorFlight*>> by_policy;
  for (const CorridorFlight& r : rows) {
    if (std::find(seeds.begin(), seeds.end(), r.corridor_seed) == seeds.end()) {
      seeds.push_back(r.corridor_seed);
    }
    by_policy[r.policy][r.corridor_seed] = &r;
  }
  for (const auto& [policy, flights] : by_policy) {
    if (policy.rfind("fixed_", 0) == 0) continue;
    CorridorComparison::Adaptive a;
    a.policy = policy;
    for (const auto& [seed, r] : flights) {
      a.mean_f_l += r->f_l / static_cast<double>(flights.size());
      a.collisions += r->collisions;
      a.lower_in_dense += r->v_des_dense > 0.0 && r->v_des_dense < r->v_des_sparse ? 1 : 0;
      ++a.corridors;
    }
    out.adaptive.push_back(a);
  }
  if (seeds.size() < 2) return out;
  for (const std::uint64_t seed : seeds) {
    CorridorVerdict v;
    v.corridor_seed = seed;
    double best = std::numeric_limits<double>::infinity();
    for (const auto& [policy, flights] : by_policy) {
      if (policy.rfind("fixed_", 0) != 0) continue;
      double sum = 0.0;
      int n = 0;
      for (const auto& [other, r] : flights) {
        if (other == seed) continue;
        sum += r->f_l;
        ++n;
      }
      if (n > 0 && sum / n < best && flights.count(seed) > 0) {
        best = sum / n;
        v.best_fixed = policy;
        v.best_fixed_f_l = flights.at(seed)->f_l;
        v.best_fixed_collisions = flights.at(seed)->collisions;
      }
    }
    if (v.best_fixed.empty()) return CorridorComparison{{}, out.adaptive, 0.0, 0};
    out.best_fixed_mean_f_l += v.best_fixed_f_l / static_cast<double>(seeds.size());
    out.best_fixed_collisions += v.best_fixed_collisions;
    out.corridors.push_back(v);
  }
  return out;
}

namespace {

// The experiment flying map `map` (seed e.seed + map) of density d's forest, one zone, go-to.
AdaptExperiment OnDensityMap(const AdaptExperiment& e, const DensityPoint& d, int map) {
  AdaptExperiment ex = e;
  ex.layout = d.layout;
  ex.layout.zones.clear();
  ex.SetSeed(e.seed + static_cast<std::uint64_t>(map));
  return ex;
}

}  // namespace

std::vector<GridCell> ChooseVDesByGrid(const AdaptExperiment& e,
                                       std::vector<DensityPoint>& densities,
                                       const std::vector<double>& grid, int maps, int threads) {
  if (grid.empty()) throw ConfigError("policy", "grid", "needs at least one v_des");
  for (const double v : grid) {
    if (!(v >= e.adaptation.v_min && v <= e.adaptation.v_max)) {
      throw ConfigError("policy", "grid",
                        "v_des " + FormatNumber(v) + " lies outside adaptation.v_des_bounds [" +
                            FormatNumber(e.adaptation.v_min) + ", " +
                            FormatNumber(e.adaptation.v_max) + "] m/s of " + e.file);
    }
  }
  const std::size_t per_density = grid.size() * static_cast<std::size_t>(maps);
  std::vector<sim::FlightMetrics> metrics(densities.size() * per_density);
  std::vector<AdaptExperiment> experiments;
  std::vector<layout::Layout> layouts;
  for (const DensityPoint& d : densities) {
    for (int m = 0; m < maps; ++m) {
      experiments.push_back(OnDensityMap(e, d, m));
      layouts.push_back(layout::GenerateLayout(experiments.back().layout, experiments.back().seed));
    }
  }
  ParallelFor(std::max(1, threads), std::size_t{0}, metrics.size(), [&](std::size_t index) {
    const std::size_t d = index / per_density;
    const std::size_t g = (index % per_density) / static_cast<std::size_t>(maps);
    const std::size_t map =
        d * static_cast<std::size_t>(maps) + index % static_cast<std::size_t>(maps);
    metrics[index] = RunAdaptFlight(experiments[map], layouts[map],
                                    FlightPolicy{grid[g], std::nullopt}, {}, nullptr)
                         .result.metrics;
  });
  std::vector<GridCell> cells;
  for (std::size_t d = 0; d < densities.size(); ++d) {
    const std::size_t first = cells.size();
    for (std::size_t g = 0; g < grid.size(); ++g) {
      GridCell c;
      c.label = densities[d].label;
      c.v_des = grid[g];
      for (int m = 0; m < maps; ++m) {
        const sim::FlightMetrics& fm =
            metrics[d * per_density + g * static_cast<std::size_t>(maps) +
                    static_cast<std::size_t>(m)];
        c.mean_f_l += CorridorFl(fm, experiments[d * static_cast<std::size_t>(maps)]) / maps;
        c.collisions += fm.collisions;
        c.unfinished += fm.status == sim::FlightStatus::kCompleted ? 0 : 1;
        ++c.flights;
      }
      cells.push_back(c);
    }
    // The lowest mean f_l among the v_des whose flights all finished without a collision,
    // else among all.
    std::size_t best = first;
    bool best_clean = false;
    for (std::size_t i = first; i < cells.size(); ++i) {
      const bool clean = cells[i].collisions == 0 && cells[i].unfinished == 0;
      if ((clean && !best_clean) ||
          (clean == best_clean && cells[i].mean_f_l < cells[best].mean_f_l)) {
        best = i;
        best_clean = clean;
      }
    }
    cells[best].chosen = true;
    densities[d].v_des = cells[best].v_des;
  }
  return cells;
}

ContextPolicy LearnContextPolicy(const AdaptExperiment& e,
                                 const std::vector<DensityPoint>& densities, int maps,
                                 int threads) {
  const int total = static_cast<int>(densities.size()) * maps;
  // Per flight, summed in map order below, so that the threads never change a policy's digits.
  std::vector<double> flight_sums(static_cast<std::size_t>(total), 0.0);
  std::vector<int> flight_counts(static_cast<std::size_t>(total), 0);
  ParallelFor(std::max(1, threads), 0, total, [&](int index) {
    const std::size_t d = static_cast<std::size_t>(index / maps);
    AdaptExperiment ex = OnDensityMap(e, densities[d], index % maps);
    ex.params.v_des = std::clamp(densities[d].v_des, ex.adaptation.v_min, ex.adaptation.v_max);
    ContextPolicy constant;
    constant.points = {{0.01, ex.params.v_des, ""}, {1e6, ex.params.v_des, ""}};
    if (e.adaptation.policy) constant.measure = e.adaptation.policy->measure;
    ex.adaptation.policy = constant;
    ex.adaptation.mode = AdaptationMode::kContext;
    const layout::Layout layout = layout::GenerateLayout(ex.layout, ex.seed);
    const AdaptFlight flight = RunAdaptFlight(ex, layout, FlightPolicy{}, {}, nullptr);
    double sum = 0.0;
    int n = 0;
    for (const AdaptationSegment& s : flight.segments) {
      if (s.free_range < 0.0) continue;
      sum += s.free_range;
      ++n;
    }
    flight_sums[static_cast<std::size_t>(index)] = sum;
    flight_counts[static_cast<std::size_t>(index)] = n;
  });
  std::vector<double> sums(densities.size(), 0.0);
  std::vector<int> counts(densities.size(), 0);
  for (int index = 0; index < total; ++index) {
    const std::size_t d = static_cast<std::size_t>(index / maps);
    sums[d] += flight_sums[static_cast<std::size_t>(index)];
    counts[d] += flight_counts[static_cast<std::size_t>(index)];
  }
  ContextPolicy policy;
  if (e.adaptation.policy) policy.measure = e.adaptation.policy->measure;
  for (std::size_t d = 0; d < densities.size(); ++d) {
    if (counts[d] == 0) continue;
    policy.points.push_back({sums[d] / counts[d], densities[d].v_des, densities[d].label});
  }
  std::stable_sort(
      policy.points.begin(), policy.points.end(),
      [](const PolicyPoint& a, const PolicyPoint& b) { return a.free_range < b.free_range; });
  policy.points.erase(std::unique(policy.points.begin(), policy.points.end(),
                                  [](const PolicyPoint& a, const PolicyPoint& b) {
                                    return !(b.free_range > a.free_range);
                                  }),
                      policy.points.end());
  policy.Validate("learned policy");
  return policy;
}

}  // namespace quadtune::engine
