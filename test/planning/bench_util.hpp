#pragma once
// Helpers shared by the planning benchmarks.

#include <cmath>
#include <cstddef>
#include <memory>
#include <vector>

#include <string>

#include "quadtune/common/random.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/trajectory_backend.hpp"
#include "quadtune/sim/flight.hpp"
#include "quadtune/sim/scenario.hpp"

namespace quadtune::planning::bench {

/// `count` parameter sets for short-term evaluations: set i takes query i mod size's parameters
/// with θ_s drawn from the benchmark experiment's box (w_col in [0.05, 5], w_dyn in [0.01, 1],
/// both log-uniform; n_pol in 3..10), from a fixed seed.
inline std::vector<PlannerParams> RandomShortTermParams(const std::vector<PlanningQuery>& queries,
                                                        int count) {
  std::vector<PlannerParams> thetas;
  Rng rng(7);
  for (int i = 0; i < count; ++i) {
    PlannerParams p = queries[static_cast<std::size_t>(i) % queries.size()].params;
    p.w_col = std::exp(Uniform(rng, std::log(0.05), std::log(5.0)));
    p.w_dyn = std::exp(Uniform(rng, std::log(0.01), std::log(1.0)));
    p.n_pol = static_cast<int>(UniformInt(rng, 3, 10));
    thetas.push_back(p);
  }
  return thetas;
}

/// A go-and-return flight (24 m out and back) at default parameters through the CGAL forest of
/// 1.3 m mean spacing with `seed`, planned by `backend`; `queries` (may be null) receives every
/// planning query.
inline sim::FlightResult FlyForest(std::uint64_t seed, const TrajectoryBackend& backend,
                                   std::vector<PlanningQuery>* queries) {
  const auto drone = physics::LoadDroneDescription(
      std::string(QUADTUNE_SOURCE_DIR) + "/assets/drones/research_1kg.yaml");
  layout::LayoutOptions options;
  options.spacing = 1.3;
  const layout::Layout forest = layout::GenerateLayout(options, seed);
  physics::WorldOptions world_options;
  world_options.collision_response = physics::CollisionResponse::kPassThrough;
  const sim::Scenario scenario = sim::Scenario::OverLayout(
      forest, sim::MissionKind::kGoAndReturn, drone, world_options, seed);
  std::shared_ptr<physics::World> world;
  sim::MakeWorld(scenario, world);
  sim::FlightHooks hooks;
  if (queries != nullptr) {
    hooks.on_plan = [&](const PlanningQuery& q, const PlanOutcome&) { queries->push_back(q); };
  }
  sim::FlightOptions flight;
  flight.log_rate_hz = 0.0;
  return sim::Fly(*world, scenario.mission, PlannerParams{}, flight, backend, hooks);
}

}  // namespace quadtune::planning::bench
