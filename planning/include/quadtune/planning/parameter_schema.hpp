#pragma once
/// \file
/// What the planner can fly, per PlannerParams field: the range PlannerParams::Validate()
/// checks and whether the field is an integer. The engine's IpoptPlanner publishes it as its
/// parameter schema (engine::ParameterInfo), against which experiment files' tuning boxes are
/// checked when they load.
///
/// Thread safety: pure functions.

#include <string>

#include "quadtune/common/yaml.hpp"

namespace quadtune::planning {

/// The allowed values of PlannerParams field `name`; unknown names throw ConfigError.
[[nodiscard]] Range ParameterRange(const std::string& name);
/// True when field `name` is an integer (n_pol, max_attempts); unknown names throw ConfigError.
[[nodiscard]] bool ParameterIsInteger(const std::string& name);

}  // namespace quadtune::planning
