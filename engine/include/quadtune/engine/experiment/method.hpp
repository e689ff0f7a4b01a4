#pragma once
/// \file
/// The tuning methods an experiment compares, with their name table (the spelling of the
/// experiment files and of the stored rows' `method` column).
///
/// Thread safety: constants only.

#include <array>

#include "quadtune/common/enum_names.hpp"

namespace quadtune::engine {

/// A tuning method compared by the experiment (paper Sec. IV-A).
enum class Method {
  kDefault,  ///< the planner's defaults, flown `flights` times
  kRandom,   ///< random search over all parameters, scored by f_l
  kPso,      ///< PSO over all parameters, scored by f_l
  kBo,       ///< Bayesian optimisation over all parameters, scored by f_l
  kBoPso,    ///< BO on θ_l by f_l + PSO on θ_s by f_s on recorded queries (the paper's method)
};
constexpr auto EnumNames(Method) {
  return std::array{EnumName{Method::kDefault, "default"}, EnumName{Method::kRandom, "random"},
                    EnumName{Method::kPso, "pso"}, EnumName{Method::kBo, "bo"},
                    EnumName{Method::kBoPso, "bo_pso"}};
}

}  // namespace quadtune::engine
