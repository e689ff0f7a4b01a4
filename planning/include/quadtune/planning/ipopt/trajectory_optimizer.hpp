#pragma once
/// \file
/// The planner's back-end: a minimum-jerk trajectory optimiser solved by Ipopt (paper Sec. III,
/// modelled on EGO-Planner's gradient-based back-end).
///
/// Given the start state, a local goal, the front-end's initial path and the distance field, it
/// minimises w_smooth·∫|jerk|² + w_col·J_col + w_dyn·J_dyn + w_time·J_time over the inner waypoints
/// and one global time scale (MinJerkProblem documents the formulation and the derivatives).
///
/// Why this formulation solves in few Ipopt iterations:
///  - few variables (3(N−1)+1 ≤ 34), all unbounded, no constraints: Ipopt runs a plain Newton
///    method with line search — no barrier-parameter continuation and no multipliers;
///  - for fixed nominal durations the spline is linear in the waypoints, so the jerk term is an
///    exact quadratic, and every Hessian is exact — the collision term's too, through the field's
///    C² distance and its curvature (DistanceField::EvaluateWithHessian) — so Ipopt takes true
///    Newton steps and converges quadratically to `tol` (a field without curvature degrades the
///    collision Hessian to Gauss–Newton: correct but linearly convergent, see stall_*);
///  - the nominal time allocation (trapezoidal profile from v_des and a_max along the initial
///    path) makes τ ≈ 1 and the waypoints ≈ metres, so the problem is well scaled;
///  - warm starts place the waypoints on the previous (executing) trajectory;
///  - callbacks allocate nothing once warm (per-thread scratch), `max_soc 0` (second-order
///    corrections only cost evaluations without constraints), and Ipopt's internal timers read
///    the vDSO clock instead of getrusage (see trajectory_optimizer.cpp).
///
/// Ipopt runs with one application per thread (thread_local, created on the first solve of a
/// thread), the option file disabled, print level 0, `linear_solver ma27` backed by the
/// thread-safe dense solver of dense_ma27.hpp, and deterministic options only (iteration
/// limit, no CPU/wall-time limit). Same inputs give bit-identical results on any thread.
///
/// Compute units (PlanResult::compute_units) count Ipopt's fixed costs of a solve and of an
/// iteration plus the evaluation work: 2 + 1.3·iterations + 0.4·(function + gradient
/// evaluations) + 0.002·distance_queries + 1e-4·(n³/3)·hessian_evaluations (n = num_variables);
/// solver_status is Ipopt's ApplicationReturnStatus.
///
/// Thread safety: TrajectoryOptimizer is immutable; Solve() may run concurrently from many threads
/// (each thread uses its own Ipopt application). A failed solve is reported in PlanResult, never
/// thrown; only invalid Options throw (in the constructor).

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/planning/distance_field.hpp"
#include "quadtune/planning/ipopt/min_jerk_problem.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/plan_result.hpp"
#include "quadtune/planning/trajectory.hpp"

namespace quadtune::planning {

/// One planning query (world frame W, SI units).
struct PlanRequest {
  Eigen::Vector3d p0_W = Eigen::Vector3d::Zero();    ///< start position (m)
  Eigen::Vector3d v0_W = Eigen::Vector3d::Zero();    ///< start velocity (m/s)
  Eigen::Vector3d a0_W = Eigen::Vector3d::Zero();    ///< start acceleration (m/s^2)
  Eigen::Vector3d goal_W = Eigen::Vector3d::Zero();  ///< local goal position (m)
  /// Goal velocity (m/s); zero when empty. The goal acceleration is zero.
  std::optional<Eigen::Vector3d> goal_v_W;
  /// Front-end path from (near) the start to (near) the goal, used to allocate time and place
  /// the initial inner waypoints. Empty: the straight segment start–goal.
  std::vector<Eigen::Vector3d> initial_path_W;
  /// Optional warm start: the previous (executing) trajectory and the time on it (s) that
  /// corresponds to this query's start. Not owned; must outlive the Solve() call.
  const Trajectory* warm_start = nullptr;
  double warm_start_time = 0.0;  ///< (s), >= 0
  /// Slow-down, (0, 1]: the time allocation flies the path at speed_scale · v_des, the
  /// feasibility penalty holds |v| below speed_scale · v_des and the goal velocity is scaled
  /// alike. The success check keeps v_des and a_max: a retry after a plan over the limits plans
  /// slower, and is judged by the real limits, not the reduced ones.
  double speed_scale = 1.0;
  /// Braking from a start faster than v_des (m/s², >= 0; 0: off). When > 0 and |v0| exceeds
  /// speed_scale · v_des, the plan may fly faster than v_des while it brakes: the time
  /// allocation slows from |v0| at this deceleration, and the feasibility penalty's speed limit
  /// is max(v_des, |v0| − braking_deceleration · t) along the nominal time t (instead of v_des
  /// from the start on, which no plan can meet without exceeding a_max). The success check is
  /// unchanged: such a plan is over v_des for a while and comes back as kDynamicsViolated, to
  /// be judged against the envelope by the caller (the online adaptation's braking check).
  double braking_deceleration = 0.0;
};

/// Solver settings (not tuned by the experiments).
struct TrajectoryOptimizerOptions {
  double sample_spacing = 0.2;     ///< spacing of penalty samples along the nominal path (m), > 0
  int min_samples_per_piece = 3;   ///< >= 1
  int max_samples_per_piece = 40;  ///< >= min_samples_per_piece
  double tolerance = 1e-8;         ///< Ipopt `tol` on the scaled problem, (0, 1e-2]
  int max_iterations = 200;        ///< Ipopt `max_iter`, >= 1
  /// Stagnation safeguard, armed only for a field whose ProvidesCurvature() is false (e.g. a
  /// trilinear ESDF without EvaluateWithHessian): there the collision Hessian is Gauss–Newton and
  /// the nearest-obstacle distance has gradient jumps (Voronoi ridges, voxel faces), so a
  /// trajectory squeezed between obstacles has its optimum on a kink where the gradient never
  /// reaches `tolerance`. Such a solve also ends (Ipopt "acceptable", message "stalled
  /// (non-smooth field)", reported as converged) when the relative objective change
  /// |Δf|/max(1,|f|) stays below this value for `stall_iterations` consecutive iterations.
  /// With a C² field (ProvidesCurvature() true) only `rounding_floor` applies.
  /// Deterministic. (0, 1e-3].
  double stall_relative_change = 1e-6;
  int stall_iterations = 3;  ///< >= 1
  /// With a C² field: a solve also ends (Ipopt "acceptable", message "stalled at the objective's
  /// rounding floor", reported as converged) when |Δf|/max(1,|f|) stays below this value for
  /// `stall_iterations` consecutive iterations: the objective is then constant to a few units in
  /// the last place, the line search backtracks to α ≈ 1e-10 without seeing a decrease, and more
  /// iterations only cost evaluations (docs/performance.md measures how many). Quadratic
  /// convergence never has three such iterations in a row before meeting `tolerance`.
  /// (0, 1e-10].
  double rounding_floor = 1e-13;
  double check_dt = 0.01;    ///< time step of the post-solve check samples (s), > 0
  /// Relative tolerance on the limits in the post-solve check: success needs
  /// max|v| <= v_des (1 + tol) and max|a| <= a_max (1 + tol). >= 0.
  double limit_tolerance = 0.05;
  /// A check sample closer than params.inflation + collision_margin (m) to an obstacle is a
  /// collision (the inflation is the drone's safety radius); a plan that starts closer than that
  /// must not come closer than its start. >= 0.
  double collision_margin = 0.0;
  double collision_scale = 100.0;    ///< κ_col of MinJerkCostParams, > 0
  double feasibility_scale = 1000.0;  ///< κ_dyn of MinJerkCostParams, > 0

  /// Throws ConfigError(origin, key, allowed range) for the first bad field.
  void Validate(const std::string& origin = "") const;
};

/// The Ipopt minimum-jerk back-end. See the file comment.
class TrajectoryOptimizer {
 public:
  /// Validates `options` (throws ConfigError).
  explicit TrajectoryOptimizer(const TrajectoryOptimizerOptions& options = {});

  /// Plans a trajectory for `request` in `field` with the planner's θ_s and limits (n_pol pieces,
  /// w_col, w_dyn, v_des, a_max, clearance, w_smooth, w_time). Never throws for solver or input
  /// failures: they come back as the result's status and message.
  [[nodiscard]] PlanResult Solve(const PlanRequest& request, const DistanceField& field,
                                 const PlannerParams& params) const;
  /// Solve() for `params` that passed PlannerParams::Validate(): the parameters are not checked
  /// again (SolveQuery checks them once per query, not once per attempt).
  [[nodiscard]] PlanResult SolveValidated(const PlanRequest& request, const DistanceField& field,
                                          const PlannerParams& params) const;

  /// Solve()'s acceptance check, for a trajectory made elsewhere (result->trajectory, starting at
  /// p0_W): samples every check_dt and at the end set result->max_speed, max_acceleration,
  /// min_clearance and duration; the status becomes kCollision (closer to an obstacle than
  /// inflation + collision_margin, or than p0_W itself where that is closer), kDynamicsViolated
  /// (over v_des or a_max by more than limit_tolerance), kNumericalError or kSuccess (empty
  /// message).
  void Check(const Eigen::Vector3d& p0_W, const DistanceField& field, const PlannerParams& params,
             PlanResult* result) const;

  /// The options.
  [[nodiscard]] const TrajectoryOptimizerOptions& Options() const { return options_; }

  /// Nominal time allocation used by Solve(): durations (s) of `num_pieces` pieces of equal arc
  /// length along `path_W` (start to goal) for a trapezoidal speed profile from `v0` to `vf`
  /// (m/s, clamped to v_max) with limits v_max, a_max. With `braking` > 0 (m/s²) a start above
  /// v_max is not clamped: the profile brakes from v0 to v_max at that deceleration first.
  /// Public for tests.
  [[nodiscard]] static std::vector<double> AllocateTime(const std::vector<Eigen::Vector3d>& path_W,
                                                        int num_pieces, double v0, double vf,
                                                        double v_max, double a_max,
                                                        double braking = 0.0);

 private:
  // Check()'s two halves: Measure fills the sampled figures and returns the clearance required;
  // Judge sets the status from them (true: kSuccess).
  double Measure(const Eigen::Vector3d& p0_W, const DistanceField& field,
                 const PlannerParams& params, PlanResult* result) const;
  bool Judge(double required_clearance, const PlannerParams& params, PlanResult* result) const;
  // Solve()'s verdict on a usable final iterate whose figures Measure filled: the status and
  // message from Ipopt's status (`ipopt_status`, an Ipopt::ApplicationReturnStatus), then Judge.
  void Conclude(int ipopt_status, bool curvature, double required_clearance,
                const PlannerParams& params, PlanResult* result) const;

  TrajectoryOptimizerOptions options_;
};

}  // namespace quadtune::planning
