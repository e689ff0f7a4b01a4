#pragma once
/// \file
/// What the planner can fly, per PlannerParams field: its role (θ_s, θ_l or fixed), the range
/// PlannerParams::Validate() checks, whether it is an integer, its default and its meaning. One
/// table in parameters.cpp holds all of it; PlannerParamsFields() (reading, writing, the
/// configuration reference), named access (PlannerParams::Get/Set) and this schema come from
/// it. The engine's IpoptPlanner publishes it as its parameter schema (engine::ParameterInfo),
/// against which experiment files' tuning boxes are checked when they load.
///
/// Thread safety: pure functions.

#include <array>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::planning {

/// Which set a planner parameter belongs to (paper Sec. IV-A).
enum class ParameterRole {
  kShortTerm,  ///< θ_s, scored right after a plan (PSO)
  kLongTerm,   ///< θ_l, scored after a flight (BayesOpt)
  kFixed,      ///< clear safety meaning; not tuned
};
constexpr auto EnumNames(ParameterRole) {
  return std::array{EnumName{ParameterRole::kShortTerm, "short_term"},
                    EnumName{ParameterRole::kLongTerm, "long_term"},
                    EnumName{ParameterRole::kFixed, "fixed"}};
}

/// One row of the planner parameter schema.
struct PlannerParameterInfo {
  std::string name;  ///< the PlannerParams field, e.g. "v_des"
  ParameterRole role;
  bool integer = false;   ///< n_pol, max_attempts
  Range range;            ///< allowed values
  double fallback = 0.0;  ///< PlannerParams{}'s value
  std::string meaning;    ///< with its unit, e.g. "re-plan interval (s)"
};

/// Every planner parameter, θ_s first, then θ_l, then the fixed ones.
[[nodiscard]] const std::vector<PlannerParameterInfo>& PlannerParameterSchema();

/// The allowed values of PlannerParams field `name`; unknown names throw ConfigError.
[[nodiscard]] Range ParameterRange(const std::string& name);
/// True when field `name` is an integer (n_pol, max_attempts); unknown names throw ConfigError.
[[nodiscard]] bool ParameterIsInteger(const std::string& name);

}  // namespace quadtune::planning
