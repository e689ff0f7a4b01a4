#pragma once
// Helpers shared by the planning benchmarks.

#include <cmath>
#include <cstddef>
#include <vector>

#include "quadtune/common/random.hpp"
#include "quadtune/planning/local_planner.hpp"

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

}  // namespace quadtune::planning::bench
