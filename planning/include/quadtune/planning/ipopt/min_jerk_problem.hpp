#pragma once
/// \file
/// The minimum-jerk trajectory problem the planner's back-end hands to Ipopt: cost, exact
/// gradient and exact Hessian (including the distance field's curvature).
///
/// Formulation (argued for Ipopt speed; see also trajectory_optimizer.hpp):
///  - The trajectory is a C^4 spline of N quintic pieces through the fixed start state
///    (p0, v0, a0), N−1 free inner waypoints q_1..q_{N−1} and the fixed goal state (pf, vf, af),
///    i.e. the unique minimum-jerk spline for those waypoints and durations (MINCO, s = 3).
///  - Durations are T_i = τ·T̄_i: the nominal allocation T̄ (from v_des, a_max and the front-end
///    path) is fixed, one global time scale τ = exp(ρ) is free. With normalised time s = t/τ the
///    spline P(s) = p(τ s) is linear in the boundary vector
///        b = (p0, τ v0, τ² a0, q_1..q_{N−1}, pf, τ vf, τ² af)      (per axis)
///    so its coefficients are c = K b with K = M(T̄)^{-1} E computed once per problem (one LU of
///    the 6N×6N banded min-jerk system). Every sampled position/velocity/acceleration is then a
///    fixed row vector times b, scaled by τ^0, τ^-1, τ^-2, and the jerk energy is
///    τ^-5 Σ_axis bᵀ H̄ b with H̄ = Kᵀ Q_jerk(T̄) K precomputed.
///  - Decision variables z = (q_x(1..N−1), q_y(...), q_z(...), ρ): 3(N−1)+1 of them, all unbounded
///    (τ > 0 by construction), so Ipopt runs a pure Newton method with line search and no barrier
///    iterations.
///  - Cost f = w_smooth·J_jerk + w_col·J_col + w_dyn·J_dyn + w_time·J_time with
///      J_jerk = ∫|jerk|² dt (closed form),
///      J_col  = κ_col Σ_samples max(0, (C − d(p_j))/C)³  (C: clearance, d: distance to the
///               obstacles as sensed, not inflated),
///      J_dyn  = κ_dyn Σ_samples [max(0, |v_j|²/v_max² − 1)³ + max(0, |a_j|²/a_max² − 1)³],
///      J_time = Σ T̄_i · ρ²  (ρ = ln τ: how much the trajectory is stretched in time),
///    samples at s = (k/K_i) T̄_i, k = 1..K_i, in every piece (with a braking envelope, see
///    MinJerkCostParams, v_max of sample j is max(v_max, v_s − b t̄_j)). κ_col, κ_dyn are fixed
///    normalisations (not tuned) that make the paper's default weights meaningful.
///    J_time makes v_des the planner's speed: the nominal allocation T̄ flies the path at v_des
///    (trapezoidal profile with a_max), and the optimiser slows the whole trajectory down (τ > 1)
///    only as far as jerk, clearance and feasibility are worth it (w_time large), as EGO-Planner
///    keeps its allocation at max_vel and stretches it only when infeasible. (A plain
///    J_time = Σ T_i against the jerk energy τ^-5 would pick its own speed, ≈ (720 L²/w_time)^{1/6}
///    for a rest-to-rest path of length L, whatever v_des is.) ρ² is also convex and exactly
///    quadratic in the variable ρ, and the optimum lies near ρ = 0, where the solve starts.
///  - Numerics: the position entries of b are taken relative to the start p0 (velocities and
///    accelerations as they are). Every term is invariant to that shift in exact arithmetic (the
///    spline reproduces constants: position rows of S_0 sum to 1, velocity and acceleration rows
///    to 0, and H̄ annihilates a constant), but in world coordinates, tens to thousands of metres
///    from the world origin, the jerk energy bᵀH̄b and the sampled velocities are small
///    differences of large products: the gradient then stops agreeing with f above Ipopt's
///    `tol`, and the line search spends its trials at that floor (docs/performance.md, "What the
///    Ipopt back end's settings save", measures both).
///    Sample positions get p0 added back before the field is read; ToTrajectory adds it to each
///    piece's constant coefficient.
///  - Derivatives: gradient and Hessian are exact for every term, the collision term included:
///    it reads d through DistanceField::EvaluateWithHessian (a C² version of the distance with
///    its exact Hessian ∇²d), so Ipopt takes true Newton steps and converges quadratically.
///    ∂²ψ/∂r² = 6κ e/C² ∇d∇dᵀ − 3κ e²/C ∇²d (e = (C − d)/C); the second part is negative
///    curvature around convex obstacles (the trajectory may pass either side), which Ipopt's
///    inertia correction handles. A field that does not override EvaluateWithHessian reports
///    ∇²d = 0, and the collision Hessian degrades to Gauss–Newton (correct, linearly convergent).
///
/// Thread safety: immutable after construction; Evaluate() is const and works in per-thread
/// scratch memory (no allocation once warm; a ValueCache allocates on its first use), so
/// concurrent calls on one object are safe if the DistanceField allows concurrent Evaluate() (its
/// documented contract) and each thread passes its own ValueCache. The problem holds a reference
/// to the field: the field must outlive it.

#include <Eigen/Core>
#include <vector>

#include "quadtune/planning/distance_field.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/plan_result.hpp"
#include "quadtune/planning/trajectory.hpp"

namespace quadtune::planning {

/// Fixed boundary states of a local trajectory (world frame W, SI units).
struct MinJerkBoundary {
  Eigen::Vector3d p0_W = Eigen::Vector3d::Zero();  ///< start position (m)
  Eigen::Vector3d v0_W = Eigen::Vector3d::Zero();  ///< start velocity (m/s)
  Eigen::Vector3d a0_W = Eigen::Vector3d::Zero();  ///< start acceleration (m/s^2)
  Eigen::Vector3d pf_W = Eigen::Vector3d::Zero();  ///< goal position (m)
  Eigen::Vector3d vf_W = Eigen::Vector3d::Zero();  ///< goal velocity (m/s)
  Eigen::Vector3d af_W = Eigen::Vector3d::Zero();  ///< goal acceleration (m/s^2)
};

/// Weights and limits of the cost (see the file comment for the terms).
struct MinJerkCostParams {
  double w_smooth = 1.0;           ///< jerk-energy weight, > 0
  double w_col = 0.5;              ///< collision-penalty weight, >= 0
  double w_dyn = 0.1;              ///< feasibility-penalty weight, >= 0
  double w_time = 20.0;            ///< time-stretch weight (1/s), >= 0 (see J_time)
  double clearance = 0.5;          ///< C: distance below which the collision penalty acts (m), > 0
  double v_max = 2.0;              ///< speed limit of the feasibility penalty (m/s), > 0
  double a_max = 3.0;              ///< acceleration limit of the feasibility penalty (m/s^2), > 0
  double collision_scale = 100.0;  ///< κ_col, fixed normalisation, > 0
  double feasibility_scale = 1000.0;  ///< κ_dyn, fixed normalisation, > 0
  /// Braking envelope (both > 0 and brake_from_speed > v_max to take effect): the speed limit
  /// of sample j is max(v_max, brake_from_speed − braking_deceleration · t̄_j), t̄_j its time
  /// from the start in the nominal allocation, instead of v_max. Off by default.
  double brake_from_speed = 0.0;      ///< (m/s), >= 0
  double braking_deceleration = 0.0;  ///< (m/s²), >= 0

  /// The planner's weights and limits (w_smooth, w_col, w_dyn, w_time, clearance, v_des, a_max).
  static MinJerkCostParams FromPlannerParams(const PlannerParams& params);
};

/// The unconstrained problem min_z f(z); see the file comment.
class MinJerkProblem {
 public:
  /// `nominal_durations` T̄_i (s, > 0, N = size >= 1 pieces); `samples_per_piece` K_i >= 1 (same
  /// size). Throws std::invalid_argument on bad sizes or values. Keeps a reference to `field`.
  MinJerkProblem(const MinJerkBoundary& boundary, std::vector<double> nominal_durations,
                 std::vector<int> samples_per_piece, const DistanceField& field,
                 const MinJerkCostParams& params);

  /// Number of pieces N.
  [[nodiscard]] int NumPieces() const { return num_pieces_; }
  /// Number of decision variables, 3(N−1)+1.
  [[nodiscard]] int NumVariables() const { return 3 * (num_pieces_ - 1) + 1; }
  /// Number of penalty samples (= distance-field queries per cost evaluation).
  [[nodiscard]] int NumSamples() const { return static_cast<int>(sample_piece_.size()); }
  /// Nominal durations T̄ (s).
  [[nodiscard]] const std::vector<double>& NominalDurations() const { return nominal_; }
  /// Boundary states.
  [[nodiscard]] const MinJerkBoundary& Boundary() const { return boundary_; }
  /// Cost parameters.
  [[nodiscard]] const MinJerkCostParams& Params() const { return params_; }

  /// z from inner waypoints (N−1 points, m) and time scale τ (> 0).
  [[nodiscard]] Eigen::VectorXd Pack(const std::vector<Eigen::Vector3d>& inner_waypoints_W,
                                     double time_scale) const;
  /// Inner waypoints (m) stored in z.
  [[nodiscard]] std::vector<Eigen::Vector3d> InnerWaypoints(const Eigen::VectorXd& z) const;
  /// Time scale τ = exp(z.back()).
  [[nodiscard]] static double TimeScale(const Eigen::VectorXd& z);

  /// What an evaluation at z keeps for the next one at the same z: the cost, the states of all
  /// samples and which samples' penalties are active. Ipopt asks for the gradient and Hessian at
  /// every accepted trial point right after its value; with a cache, that evaluation differentiates
  /// only the active samples and repeats no state. The results are the same bits with or without
  /// one. A cache belongs to one caller (one thread); it may serve several problems and points
  /// (it recognises the problem and the exact z it holds), and must not outlive the problem.
  class ValueCache {
   public:
    ValueCache() = default;

   private:
    friend class MinJerkProblem;
    [[nodiscard]] bool Holds(const MinJerkProblem* problem, const Eigen::VectorXd& z) const;

    bool valid_ = false;
    const MinJerkProblem* owner_ = nullptr;
    Eigen::VectorXd z_;
    PlanCostTerms terms_;
    Eigen::MatrixXd b_;           // boundary vectors at z_
    Eigen::MatrixXd hb_;          // H̄ b
    double g0_ = 0.0;             // Σ_a b_aᵀ H̄ b_a
    Eigen::MatrixXd w_[3];        // S_d b: every sample's (unscaled) state, d = 0, 1, 2
    std::vector<int> active_[3];  // samples whose penalty is positive, in order
  };

  /// Cost terms at z; writes ∇f into *grad (resized) and the full symmetric Hessian ∇²f into
  /// *hess (resized) when non-null. The collision term uses DistanceField::EvaluateWithHessian
  /// (value and derivatives of the same C² function). `cache` (optional): reused when it holds
  /// this problem at this z, else refilled (see ValueCache).
  PlanCostTerms Evaluate(const Eigen::VectorXd& z, Eigen::VectorXd* grad, Eigen::MatrixXd* hess,
                         ValueCache* cache = nullptr) const;

  /// The trajectory (real time) for z.
  [[nodiscard]] Trajectory ToTrajectory(const Eigen::VectorXd& z) const;

 private:
  class GradientPass;  // Evaluate()'s derivative steps (min_jerk_problem.cpp)
  int BoundarySize() const { return num_pieces_ + 5; }
  // Boundary vector per axis (nb × 3), positions relative to p0 (see "Numerics").
  void BoundaryVectors(const Eigen::VectorXd& z, Eigen::MatrixXd* b) const;
  // The cost at z and its active samples, into *cache.
  void EvaluateValue(const Eigen::VectorXd& z, ValueCache* cache) const;
  // The feasibility penalty's violation |r|²/limit² − 1 at sample j (d = 1: r its velocity, the
  // limit v_max or the braking envelope's; d = 2: its acceleration, a_max), 1/limit² into *inv_l.
  double RateViolation(int d, int j, const Eigen::Vector3d& r, double* inv_l) const {
    *inv_l = d == 1 && !inv_speed_limit_sq_.empty()
                 ? inv_speed_limit_sq_[static_cast<std::size_t>(j)]
                 : inv_limit_sq_[d];
    return r.squaredNorm() * *inv_l - 1.0;
  }

  MinJerkBoundary boundary_;
  std::vector<double> nominal_;
  const DistanceField* field_;
  MinJerkCostParams params_;
  int num_pieces_ = 0;
  Eigen::MatrixXd coeff_map_;  // K: 6N × nb
  Eigen::MatrixXd jerk_hess_;  // H̄: nb × nb
  // H̄ᵀ by rows (H̄'s columns) with a row stride of nb rounded up to 4, zero-padded: the l of
  // AddTransposedProduct for H̄ b (empty where that does not apply).
  std::vector<double> jerk_hess_rows_;
  double sum_nominal_ = 0.0;  // Σ T̄ (s)
  // Per-sample rows (nb) for position, normalised velocity and acceleration: S_d (ns × nb).
  Eigen::MatrixXd sample_rows_[3];
  std::vector<int> sample_piece_;
  // 1/v_max², 1/a_max² at [1], [2] (of the feasibility penalty; [0] unused).
  double inv_limit_sq_[3] = {0.0, 0.0, 0.0};
  // Per-sample 1/limit² of the speed penalty under a braking envelope; empty: 1/v_max² for all.
  std::vector<double> inv_speed_limit_sq_;
};

}  // namespace quadtune::planning
