#pragma once
/// \file
/// What a trajectory back end returns for one solve: the trajectory, its status and the figures
/// the acceptance check measured (PlanResult), with the status names stored with the results.
///
/// Thread safety: value types; concurrent const use is safe.

#include <array>
#include <string>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/planning/trajectory.hpp"

namespace quadtune::planning {

/// A solve's cost split into its terms (unweighted) and the weighted total. The Ipopt back end
/// fills every term (MinJerkProblem's J_jerk, J_col, J_dyn, J_time); the EGO back end fills jerk
/// with its trajectory's ∫|jerk|² dt and collision, feasibility and total with its own terms
/// (ego_optimizer.hpp).
struct PlanCostTerms {
  double jerk = 0.0;         ///< J_jerk, ∫|jerk|² dt (m^2/s^5)
  double collision = 0.0;    ///< J_col (dimensionless)
  double feasibility = 0.0;  ///< J_dyn (dimensionless)
  double time = 0.0;   ///< J_time = ΣT̄ (ln τ)², time stretch (s); the duration is τ ΣT̄
  double total = 0.0;  ///< weighted sum f
};

/// Outcome of a solve, by any back end.
enum class PlanStatus {
  kSuccess,           ///< converged, collision-free on the check samples, within the limits
  kCollision,         ///< converged but a check sample is closer than inflation + collision_margin
  kDynamicsViolated,  ///< converged, collision-free, but over the v/a limits (with tolerance)
  kMaxIterations,     ///< the solver's iteration limit (the last iterate is returned)
  kSolverFailure,     ///< the solver failed (Ipopt: restoration, step computation, ...)
  kNumericalError,    ///< NaN/Inf in the cost, derivatives or result
  kInvalidInput,      ///< the request or parameters are invalid (nothing solved)
};

/// Short names ("success", "collision", ...), as stored with the results.
constexpr auto EnumNames(PlanStatus) {
  return std::array{EnumName{PlanStatus::kSuccess, "success"},
                    EnumName{PlanStatus::kCollision, "collision"},
                    EnumName{PlanStatus::kDynamicsViolated, "dynamics_violated"},
                    EnumName{PlanStatus::kMaxIterations, "max_iterations"},
                    EnumName{PlanStatus::kSolverFailure, "solver_failure"},
                    EnumName{PlanStatus::kNumericalError, "numerical_error"},
                    EnumName{PlanStatus::kInvalidInput, "invalid_input"}};
}
using quadtune::ToString;

/// Summary of one solve (TrajectoryBackend::Solve and Fallback). The counters and cost terms
/// are the back end's own: each back end's header says what it counts.
struct PlanResult {
  Trajectory trajectory;  ///< the optimised trajectory (empty when nothing was solved)
  PlanStatus status = PlanStatus::kInvalidInput;
  std::string message;            ///< human-readable detail (solver status, reason of failure)
  PlanCostTerms cost;             ///< cost terms at the solution
  double max_speed = 0.0;         ///< max |v_W| on the check samples (m/s)
  double max_acceleration = 0.0;  ///< max |a_W| on the check samples (m/s^2)
  double min_clearance = 0.0;     ///< min distance-field value on the check samples (m)
  double duration = 0.0;          ///< trajectory duration (s)
  double solve_time_s = 0.0;      ///< wall-clock time t_c of the whole Solve() call (s)
  int iterations = 0;             ///< solver iterations
  int function_evaluations = 0;   ///< objective evaluations
  int gradient_evaluations = 0;   ///< gradient evaluations
  int hessian_evaluations = 0;    ///< Hessian evaluations
  /// Distance-field samples of the cost evaluations the solver requested (samples × requests; a
  /// request served from an evaluation cache counts too, so caching never changes it)
  long distance_queries = 0;
  int num_variables = 0;          ///< decision variables
  /// Deterministic cost measure (same inputs → same value on any machine/thread): a weighted
  /// count of the work done in nominal units of 0.1 ms (docs/design.md, "Compute units"; each
  /// back end's header gives its formula). Use it, not solve_time_s, where an experiment must be
  /// exactly reproducible; it is not a wall-clock prediction.
  double compute_units = 0.0;
  int solver_status = 0;  ///< the solver's raw return code (Ipopt: ApplicationReturnStatus)

  /// True for kSuccess.
  [[nodiscard]] bool Ok() const { return status == PlanStatus::kSuccess; }
};

}  // namespace quadtune::planning
