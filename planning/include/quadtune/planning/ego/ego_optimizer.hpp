#pragma once
/// \file
/// The EGO-Planner back end (Zhou et al., "EGO-Planner: An ESDF-free Gradient-based Local Planner
/// for Quadrotors", RA-L 2021): a uniform cubic B-spline optimised by L-BFGS (libLBFGS) against
/// an ESDF-free collision term, on the occupancy snapshot of a planning query.
///
/// Trajectory. Control points Q_0..Q_{N−1} (m, W), N = n + 3 for n knot spans of Δt seconds each;
/// span k is p(u) = [(1−u)³Q_k + (3u³−6u²+4)Q_{k+1} + (−3u³+3u²+3u+1)Q_{k+2} + u³Q_{k+3}]/6,
/// u = τ/Δt ∈ [0, 1]. The first three control points are fixed by the start state (p0, v0, a0),
/// the last three by the goal state (goal, goal_v, 0); the N − 6 others are the variables.
/// The initial control points lie on the front-end path, spread evenly by arc length:
/// n = max(4, ⌈L / d⌉) spans for a path of length L with spacing d = h_pl / (n_pol ·
/// segments_per_pol) — n_pol (θ_s) counts groups of segments_per_pol spans over the horizon, so
/// n_pol = 5 with 4 spans each gives 20 spans over 7.5 m, 0.375 m apart (EGO-Planner's
/// ctrl_pt_dist 0.4 m). Δt allocates the path at v_des (and a rest-to-rest profile at a_max
/// where that is slower).
///
/// Cost J = w_smooth·J_s + w_col·J_c + w_dyn·J_d (+ fitness while refitting):
///  - J_s = Σ|Q_{i+2} − 2Q_{i+1} + Q_i|² + Σ|Q_{i+3} − 3Q_{i+2} + 3Q_{i+1} − Q_i|²: the control
///    polygon's acceleration and jerk, as geometric differences (Δt²A_i, Δt³J_i; m²);
///  - J_c = Σ over repulsion pairs {p, v} of control point i: F(s_f − (Q_i − p)·v) with
///    F(c) = 0 (c ≤ 0), c³ (0 < c ≤ s_f), 3s_f c² − 3s_f² c + s_f³ (c > s_f); s_f = clearance;
///  - J_d = Σ_i (|V_i| − v_des)₊² + Σ_i (|A_i| − a_max)₊², V_i = (Q_{i+1} − Q_i)/Δt,
///    A_i = (V_{i+1} − V_i)/Δt (by the convex hull property these bound the curve's speed and
///    acceleration).
/// Repulsion pairs (MakeRepulsionPairs) come from an A* path Γ on the occupancy snapshot around
/// each run of colliding control points; no distance field is read. Rebound: after each L-BFGS
/// solve the curve is checked again, new colliding control points get pairs and the problem is
/// solved again (max_rebounds rounds). Time reallocation: when the curve exceeds v_des or a_max by
/// more than limit_tolerance, Δt grows by r = max(|V|max/v_des, √(|A|max/a_max)) and the control
/// points are refit to the previous curve (anisotropic fitness at the knots: across-track error
/// weighted 1, along-track fitness_along_weight) and optimised again (max_reallocations rounds).
///
/// Acceptance check (the same rule as the Ipopt back end's, on the occupancy map): samples every
/// check_dt must be outside the inflated obstacles (a plan that starts inside the inflation may
/// leave it but not re-enter), and within v_des, a_max by limit_tolerance.
///
/// Determinism: no wall-clock in the results except solve_time_s; compute_units count the work
/// (see EgoOptions::compute_units). Thread safety: all functions are pure or use only their
/// arguments; EgoBackend is immutable and may Solve from many threads (libLBFGS is reentrant).

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/planning/local_map.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/path_search.hpp"
#include "quadtune/planning/plan_result.hpp"
#include "quadtune/planning/trajectory.hpp"
#include "quadtune/planning/trajectory_backend.hpp"

namespace quadtune::planning {

/// Control points, one column each (m, W).
using ControlPoints = Eigen::Matrix3Xd;

/// Settings of the EGO back end (not tuned by the experiments).
struct EgoOptions {
  int segments_per_pol = 4;        ///< B-spline spans per n_pol unit over the horizon, [1, 16]
  int max_rebounds = 4;            ///< rebound rounds after the first solve, [0, 20]
  int max_reallocations = 3;       ///< time-reallocation rounds, [0, 10]
  int lbfgs_memory = 4;            ///< L-BFGS history, [1, 64]
  int lbfgs_max_iterations = 200;  ///< per solve, [1, 10000]
  double lbfgs_epsilon = 1e-3;     ///< libLBFGS relative gradient tolerance, (0, 1)
  double lbfgs_delta = 1e-3;       ///< relative decrease over 3 iterations to stop, [0, 1)
  double fitness_along_weight = 0.1;  ///< along-track weight of the refit, (0, 1]
  double fitness_weight = 1.0;     ///< weight of the refit's fitness term, > 0
  double check_dt = 0.01;          ///< acceptance-check sample spacing (s), > 0
  double clearance_dt = 0.1;       ///< min_clearance sample spacing (s), > 0
  double limit_tolerance = 0.05;   ///< relative tolerance on v_des and a_max, >= 0
  double gamma_search_margin = 1.5;  ///< A* box widening for Γ (m), [0, 50]
  int gamma_max_expansions = 20000;  ///< A* expansions for one Γ, >= 1
  /// EgoBackend::Fallback flies the front end's path stop-and-go; off: it has no fallback.
  bool stop_and_go = false;

  /// Throws ConfigError(origin, key, allowed range) for the first bad field.
  void Validate(const std::string& origin = "") const;
};

/// A repulsion pair of control point `index`: obstacle surface point p (m) and direction v (unit).
struct RepulsionPair {
  int index = 0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  Eigen::Vector3d v = Eigen::Vector3d::UnitX();
};

/// Three consecutive control points (columns) of a uniform cubic B-spline with knot span dt (s)
/// whose curve has position p, velocity v and acceleration a at the knot between the first two
/// spans they support: Q_0..Q_2 for the start state, Q_{N−3}..Q_{N−1} for the end state.
[[nodiscard]] Eigen::Matrix3d BoundaryControlPoints(const Eigen::Vector3d& p,
                                                    const Eigen::Vector3d& v,
                                                    const Eigen::Vector3d& a, double dt);

/// The B-spline (N >= 4 control points, knot span dt > 0 s) as a piecewise polynomial Trajectory
/// of N − 3 pieces of dt each (cubic; the quintic's two highest coefficients are zero).
[[nodiscard]] Trajectory BsplineToTrajectory(const ControlPoints& q, double dt);

/// Repulsion pairs for the control points flagged in `colliding` (size N), which must lie in
/// [3, N−4]: runs of consecutive flagged points are joined through an A* path Γ (on `map`'s
/// inflated occupancy) between the nearest free control points before and after the run; each
/// flagged Q_i gets the point where the plane through Q_i normal to Q_{i+1} − Q_{i−1} meets Γ
/// (nearest point of Γ when the plane misses it), R_i from Q_i to it, and marches along R_i in
/// resolution/2 steps to the first free point after an occupied one: that is p, and v = R_i/|R_i|.
/// A point whose march meets no obstacle, or whose run has no Γ, gets no pair.
/// `expansions` (may be null) accumulates A* expansions.
[[nodiscard]] std::vector<RepulsionPair> MakeRepulsionPairs(const LocalMap& map,
                                                            const ControlPoints& q,
                                                            const std::vector<bool>& colliding,
                                                            PathSearcher& searcher,
                                                            long* expansions = nullptr);

/// Values of the cost terms (see the file comment).
struct EgoCostTerms {
  double smoothness = 0.0;   ///< J_s (m²)
  double collision = 0.0;    ///< J_c (m³)
  double feasibility = 0.0;  ///< J_d
  double fitness = 0.0;      ///< refit term (m²), 0 without targets
  double total = 0.0;        ///< weighted sum
};

/// The EGO cost over the free control points Q_3..Q_{N−4} (x: their coordinates, column by
/// column, size 3(N − 6)). Holds copies of its inputs.
class EgoCost {
 public:
  /// `q`: all control points (the fixed ones are read from it; N >= 7); dt > 0 (s); weights
  /// from params (w_smooth, w_col, w_dyn, v_des, a_max, clearance).
  EgoCost(ControlPoints q, double dt, std::vector<RepulsionPair> pairs, const PlannerParams& params);

  /// Adds the refit's fitness term: the curve at knot j (j = 1..N−4, the point
  /// (Q_{j−1} + 4Q_j + Q_{j+1})/6) should lie at targets.col(j − 1) (m), with unit tangents
  /// tangents.col(j − 1); `along_weight` scales the along-track error, `weight` the term.
  void SetFitness(Eigen::Matrix3Xd targets, Eigen::Matrix3Xd tangents, double along_weight,
                  double weight);

  /// Number of variables 3(N − 6).
  [[nodiscard]] int NumVariables() const { return 3 * (static_cast<int>(q_.cols()) - 6); }
  /// The variables of the stored control points.
  [[nodiscard]] Eigen::VectorXd Variables() const;
  /// All control points with the free ones taken from x.
  [[nodiscard]] ControlPoints WithVariables(const double* x) const;
  /// Cost at x (size NumVariables()); writes the gradient to grad (may be null) and the terms to
  /// terms (may be null).
  double Evaluate(const double* x, double* grad, EgoCostTerms* terms = nullptr) const;

 private:
  ControlPoints q_;
  double dt_;
  std::vector<RepulsionPair> pairs_;
  PlannerParams params_;
  Eigen::Matrix3Xd fit_targets_, fit_tangents_;
  double fit_along_ = 0.1;
  double fit_weight_ = 0.0;
};

/// Counters of one EGO solve (deterministic).
struct EgoSolveStats {
  int lbfgs_runs = 0;          ///< L-BFGS solves (first, rebounds, refits)
  int iterations = 0;          ///< L-BFGS iterations over all runs
  int evaluations = 0;         ///< cost evaluations over all runs
  long expansions = 0;         ///< A* expansions for Γ
  int rebounds = 0;            ///< rebound rounds that added pairs
  int reallocations = 0;       ///< time reallocations
  int pairs = 0;               ///< repulsion pairs at the end
  int lbfgs_status = 0;        ///< libLBFGS return code of the last run
};

/// Plans a trajectory for `query` (which must carry an occupancy snapshot) with `params`; the
/// initial knot span is multiplied by time_scale (>= 1: slower); the result's trajectory is the
/// B-spline's (BsplineToTrajectory), checked as in the file comment.
/// compute_units = 1 + evaluations · variables/1200 + expansions/2000 + 0.02·check samples, in nominal
/// units of 0.1 ms. `stats` (may be null) receives the counters; `control_points`/`knot_span`
/// (may be null) the final B-spline. Never throws for planning failures.
[[nodiscard]] PlanResult SolveEgo(const PlanningQuery& query, const PlannerParams& params,
                                  const EgoOptions& options, double time_scale = 1.0,
                                  EgoSolveStats* stats = nullptr,
                                  ControlPoints* control_points = nullptr,
                                  double* knot_span = nullptr);

/// The EGO back end (see trajectory_backend.hpp). Solve() runs SolveEgo up to params.max_attempts
/// times, attempt k with time_scale = 1/retry_slowdown^k (LocalPlannerOptions), until one passes
/// the check. With EgoOptions::stop_and_go, Fallback() flies the front end's path stop-and-go
/// (StopAndGo, quintic.hpp), judged by the same check: a drone stopped where every optimised
/// curve fails (next to an obstacle it braked for) gets away along the path; without, nullopt.
class EgoBackend final : public TrajectoryBackend {
 public:
  /// Validates `options`.
  explicit EgoBackend(const EgoOptions& options = {});

  [[nodiscard]] std::string Name() const override { return "ego"; }
  [[nodiscard]] QuerySnapshot Snapshot() const override { return QuerySnapshot::kOccupancy; }
  [[nodiscard]] PlanOutcome Solve(const PlanningQuery& query, const PlannerParams& params,
                                  const LocalPlannerOptions& options) const override;
  [[nodiscard]] std::optional<PlanResult> Fallback(const PlanningQuery& query,
                                                   const PlannerParams& params,
                                                   double speed) const override;
  [[nodiscard]] const EgoOptions& options() const { return options_; }

 private:
  EgoOptions options_;
};

}  // namespace quadtune::planning
