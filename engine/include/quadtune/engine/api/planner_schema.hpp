#pragma once
/// \file
/// The parameter schema of a planner type (PlannerSchema): what a registration gives the registry
/// (planner_registry.hpp) and what a built-in planner states about itself (planners.hpp).
///
/// Thread safety: a value type; concurrent const use is safe.

#include <vector>

#include "quadtune/engine/api/planner.hpp"

namespace quadtune::engine {

/// The tunable parameters of a planner type: θ_s and θ_l, each with the values the planner can
/// fly (ParameterInfo::range), whether it is an integer, and its default when the `planner:` map
/// fixes nothing. An experiment's tuning box must lie inside these ranges (checked on load), and
/// the plug-in a factory builds must report exactly these names, ranges and integer flags (its
/// defaults may differ: the `planner:` map may set them).
struct PlannerSchema {
  std::vector<ParameterInfo> short_term;  ///< θ_s
  std::vector<ParameterInfo> long_term;   ///< θ_l

  /// The schema a plug-in reports (its ShortTermParameters and LongTermParameters).
  static PlannerSchema Of(const Planner& planner) {
    return {planner.ShortTermParameters(), planner.LongTermParameters()};
  }
};

}  // namespace quadtune::engine
