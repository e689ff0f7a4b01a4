#include "quadtune/planning/ipopt/trajectory_optimizer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <coin/IpIpoptApplication.hpp>
#include <coin/IpSolveStatistics.hpp>
#include <coin/IpTNLP.hpp>
#include <cstring>
#include <exception>
#include <limits>
#include <optional>
#include <utility>

#include "ipopt_timers.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/planning/ipopt/dense_ma27.hpp"
#include "quadtune/planning/ipopt/ipopt_application.hpp"

namespace quadtune::planning {
namespace {

using Ipopt::Index;
using Ipopt::Number;

// Largest stretch (and compression) of the nominal time allocation a solution may have.
constexpr double kMaxTimeScale = 100.0;

// Cumulative arc length of a polyline.
std::vector<double> ArcLengths(const std::vector<Eigen::Vector3d>& path) {
  std::vector<double> s(path.size(), 0.0);
  for (std::size_t k = 1; k < path.size(); ++k) s[k] = s[k - 1] + (path[k] - path[k - 1]).norm();
  return s;
}

// Point at arc length `target` on the polyline.
Eigen::Vector3d PointAt(const std::vector<Eigen::Vector3d>& path, const std::vector<double>& s,
                        double target) {
  if (target <= 0.0) return path.front();
  for (std::size_t k = 1; k < path.size(); ++k) {
    if (target <= s[k]) {
      const double len = s[k] - s[k - 1];
      const double f = len > 0.0 ? (target - s[k - 1]) / len : 0.0;
      return path[k - 1] + f * (path[k] - path[k - 1]);
    }
  }
  return path.back();
}

// The Ipopt view of a MinJerkProblem: unconstrained, dense lower-triangular Hessian.
class MinJerkTnlp final : public UnconstrainedDenseTnlp {
 public:
  MinJerkTnlp(const MinJerkProblem& problem, Eigen::VectorXd z0)
      : UnconstrainedDenseTnlp(problem.NumVariables()), problem_(problem), z0_(std::move(z0)) {}

  bool get_starting_point(Index n, bool init_x, Number* x, bool /*init_z*/, Number* /*z_L*/,
                          Number* /*z_U*/, Index /*m*/, bool /*init_lambda*/,
                          Number* /*lambda*/) override {
    if (init_x) {
      for (Index i = 0; i < n; ++i) x[i] = z0_(i);
    }
    return true;
  }

  bool eval_f(Index n, const Number* x, bool new_x, Number& obj_value) override {
    ++f_evals_;
    if (!Prepare(n, x, new_x, /*level=*/1)) return false;
    obj_value = value_;
    return std::isfinite(value_);
  }

  bool eval_grad_f(Index n, const Number* x, bool new_x, Number* grad_f) override {
    ++grad_evals_;
    if (!Prepare(n, x, new_x, /*level=*/2)) return false;
    for (Index i = 0; i < n; ++i) grad_f[i] = grad_(i);
    return grad_.allFinite();
  }

  bool eval_h(Index n, const Number* x, bool new_x, Number obj_factor, Index /*m*/,
              const Number* /*lambda*/, bool /*new_lambda*/, Index /*nele_hess*/, Index* iRow,
              Index* jCol, Number* values) override {
    if (values == nullptr) {
      DenseLowerStructure(n, iRow, jCol);
      return true;
    }
    ++hess_evals_;
    if (!Prepare(n, x, new_x, /*level=*/2)) return false;
    Index k = 0;
    for (Index r = 0; r < n; ++r) {
      for (Index c = 0; c <= r; ++c) values[k++] = obj_factor * hess_(r, c);
    }
    return hess_.allFinite();
  }

  void finalize_solution(Ipopt::SolverReturn /*status*/, Index n, const Number* x,
                         const Number* /*z_L*/, const Number* /*z_U*/, Index /*m*/,
                         const Number* /*g*/, const Number* /*lambda*/, Number /*obj_value*/,
                         const Ipopt::IpoptData* /*ip_data*/,
                         Ipopt::IpoptCalculatedQuantities* /*ip_cq*/) override {
    z_final_ = Eigen::Map<const Eigen::VectorXd>(x, n);
    has_final_ = true;
  }

  [[nodiscard]] bool HasFinal() const { return has_final_; }
  [[nodiscard]] const Eigen::VectorXd& Final() const { return z_final_; }
  [[nodiscard]] int FunctionEvaluations() const { return f_evals_; }
  [[nodiscard]] int GradientEvaluations() const { return grad_evals_; }
  [[nodiscard]] int HessianEvaluations() const { return hess_evals_; }
  [[nodiscard]] long DistanceQueries() const { return distance_queries_; }
  /// The cost terms at z when the last evaluation was at exactly z (the final iterate usually
  /// is), else null.
  [[nodiscard]] const PlanCostTerms* TermsAt(const Eigen::VectorXd& z) const {
    return EvaluatedAt(z.data(), static_cast<Index>(z.size())) ? &terms_ : nullptr;
  }

 private:
  // Evaluates the cost at x up to `level` (1: value; 2: value, gradient and Hessian), reusing
  // the evaluation at the same point. The Hessian is computed with the gradient because Ipopt
  // asks for it at every accepted iterate right after the gradient. Ipopt flags `new_x` by the
  // identity of its vector, not by the values: its gradient-based scaling evaluates the starting
  // point in a vector of its own, and the first iterate holds the same bits in another. The
  // values are compared, so that point is evaluated once.
  // True when an evaluation is held at exactly these bits of x.
  [[nodiscard]] bool EvaluatedAt(const Number* x, Index n) const {
    return cached_level_ > 0 && z_.size() == n &&
           std::memcmp(z_.data(), x, sizeof(Number) * static_cast<std::size_t>(n)) == 0;
  }

  bool Prepare(Index n, const Number* x, bool new_x, int level) {
    const bool same_point = EvaluatedAt(x, n);
    if (new_x || cached_level_ == 0) {
      // The query count (PlanResult::distance_queries) follows Ipopt's requests: a point Ipopt
      // flags as new counts again, whether or not its evaluation is reused.
      counted_level_ = 0;
      if (!same_point) {
        cached_level_ = 0;
        z_.resize(n);
        std::copy(x, x + n, z_.data());
      }
    }
    if (counted_level_ < level) {
      distance_queries_ += problem_.NumSamples();
      counted_level_ = level;
    }
    if (cached_level_ >= level) return true;
    terms_ = level >= 2 ? problem_.Evaluate(z_, &grad_, &hess_, &cache_)
                        : problem_.Evaluate(z_, nullptr, nullptr, &cache_);
    value_ = terms_.total;
    cached_level_ = level;
    return true;
  }

  const MinJerkProblem& problem_;
  MinJerkProblem::ValueCache cache_;
  Eigen::VectorXd z0_;
  Eigen::VectorXd z_;
  int cached_level_ = 0;   // evaluated at z_: 0 nothing, 1 value, 2 also the derivatives
  int counted_level_ = 0;  // the same, as Ipopt has requested it since it last flagged new_x
  PlanCostTerms terms_;
  double value_ = 0.0;
  Eigen::VectorXd grad_;
  Eigen::MatrixXd hess_;
  Eigen::VectorXd z_final_;
  bool has_final_ = false;
  int f_evals_ = 0;
  int grad_evals_ = 0;
  int hess_evals_ = 0;
  long distance_queries_ = 0;
};

// One Ipopt application per thread: a new one per solve would add its creation to every solve
// (NewPlannerIpoptApplication).
Ipopt::IpoptApplication& ThreadApplication() {
  thread_local Ipopt::SmartPtr<Ipopt::IpoptApplication> app = NewPlannerIpoptApplication();
  return *app;
}

PlanResult Invalid(std::string message) {
  PlanResult r;
  r.status = PlanStatus::kInvalidInput;
  r.message = std::move(message);
  return r;
}

// Why `request` cannot be planned (a PlanStatus::kInvalidInput message), if so; `vf` is the
// requested final velocity.
std::optional<std::string> RequestError(const PlanRequest& request, const Eigen::Vector3d& vf) {
  if (!request.p0_W.allFinite() || !request.v0_W.allFinite() || !request.a0_W.allFinite() ||
      !request.goal_W.allFinite() || !vf.allFinite()) {
    return "start state or goal is not finite";
  }
  for (const auto& p : request.initial_path_W) {
    if (!p.allFinite()) return "initial path has a non-finite point";
  }
  if (!(request.warm_start_time >= 0.0) || !std::isfinite(request.warm_start_time)) {
    return "warm_start_time must be finite and >= 0";
  }
  if (!(request.speed_scale > 0.0 && request.speed_scale <= 1.0)) {
    return "speed_scale must be in (0, 1]";
  }
  if (!(request.braking_deceleration >= 0.0) || !std::isfinite(request.braking_deceleration)) {
    return "braking_deceleration must be finite and >= 0";
  }
  return std::nullopt;
}

// The polyline start → goal through the front end's points (repeated points dropped).
std::vector<Eigen::Vector3d> PathThrough(const PlanRequest& request) {
  std::vector<Eigen::Vector3d> path{request.p0_W};
  for (const auto& p : request.initial_path_W) {
    if ((p - path.back()).norm() > 1e-6) path.push_back(p);
  }
  if ((request.goal_W - path.back()).norm() > 1e-6) path.push_back(request.goal_W);
  return path;
}

// The cost parameters of one solve: the planner's, with the request's speed scale and braking.
MinJerkCostParams CostParamsFor(const PlanRequest& request, const PlannerParams& params,
                                const TrajectoryOptimizerOptions& options) {
  MinJerkCostParams cost_params = MinJerkCostParams::FromPlannerParams(params);
  cost_params.v_max = request.speed_scale * params.v_des;  // the check keeps params.v_des
  cost_params.collision_scale = options.collision_scale;
  cost_params.feasibility_scale = options.feasibility_scale;
  cost_params.brake_from_speed = request.v0_W.norm();
  cost_params.braking_deceleration = request.braking_deceleration;
  return cost_params;
}

// Initial guess: waypoints at equal arc length on `path` (τ = 1), or on the previous trajectory
// where it covers the new knots.
Eigen::VectorXd InitialGuess(const MinJerkProblem& problem, const PlanRequest& request,
                             const std::vector<Eigen::Vector3d>& path,
                             const std::vector<double>& arc, const std::vector<double>& nominal) {
  const double length = arc.back();
  const int n_pieces = static_cast<int>(nominal.size());
  double tau0 = 1.0;
  double sum_nominal = 0.0;
  for (double t : nominal) sum_nominal += t;
  const Trajectory* prev = request.warm_start;
  const bool warm = prev != nullptr && !prev->Empty();
  if (warm) {
    const double remaining = prev->Duration() - request.warm_start_time;
    if (remaining > 0.0 &&
        (prev->Position(prev->Duration()) - request.goal_W).norm() < 0.05 * std::max(1.0, length)) {
      tau0 = std::clamp(remaining / sum_nominal, 0.2, 5.0);
    }
  }
  std::vector<Eigen::Vector3d> inner;
  inner.reserve(static_cast<std::size_t>(n_pieces - 1));
  double knot_time = 0.0;
  for (int i = 1; i < n_pieces; ++i) {
    knot_time += tau0 * nominal[static_cast<std::size_t>(i - 1)];
    const double t_prev = request.warm_start_time + knot_time;
    if (warm && t_prev < prev->Duration()) {
      inner.push_back(prev->Position(t_prev));
    } else {
      inner.push_back(PointAt(path, arc, length * i / n_pieces));
    }
  }
  return problem.Pack(inner, tau0);
}

// The per-solve options of the thread's application.
void SetSolveOptions(Ipopt::IpoptApplication& app, const TrajectoryOptimizerOptions& options,
                     bool curvature) {
  app.Options()->SetNumericValue("tol", options.tolerance);
  app.Options()->SetIntegerValue("max_iter", options.max_iterations);
  // Stagnation safeguards (TrajectoryOptimizerOptions::stall_relative_change, rounding_floor):
  // Ipopt's "acceptable" termination with only its objective-change part active. For a field
  // without curvature, whose Gauss–Newton model and kinked gradient keep Newton from reaching
  // `tol`, at stall_relative_change; for a C² field (ProvidesCurvature()) only at the
  // objective's rounding floor, where the line search can no longer tell f(x + αd) from f(x).
  app.Options()->SetNumericValue("acceptable_tol", 1e19);
  app.Options()->SetNumericValue("acceptable_dual_inf_tol", 1e19);
  app.Options()->SetNumericValue("acceptable_obj_change_tol", curvature
                                                                  ? options.rounding_floor
                                                                  : options.stall_relative_change);
  app.Options()->SetIntegerValue("acceptable_iter", options.stall_iterations);
}

// The solver's effort: evaluation counts, iterations and the machine-independent compute units.
void RecordEffort(const MinJerkProblem& problem, const MinJerkTnlp& tnlp,
                  Ipopt::IpoptApplication& app, PlanResult* result) {
  result->num_variables = problem.NumVariables();
  result->function_evaluations = tnlp.FunctionEvaluations();
  result->gradient_evaluations = tnlp.GradientEvaluations();
  result->hessian_evaluations = tnlp.HessianEvaluations();
  result->distance_queries = tnlp.DistanceQueries();
  if (Ipopt::SmartPtr<Ipopt::SolveStatistics> stats = app.Statistics(); Ipopt::IsValid(stats)) {
    result->iterations = stats->IterationCount();
  }
  const double nv = result->num_variables;
  result->compute_units = 2.0 + 1.3 * result->iterations +
                          0.4 * (result->function_evaluations + result->gradient_evaluations) +
                          0.002 * static_cast<double>(result->distance_queries) +
                          1e-4 * (nv * nv * nv / 3.0) * result->hessian_evaluations;
}

// Why the final iterate of a solve with `ipopt_status` is not a trajectory, if so.
std::optional<std::pair<PlanStatus, std::string>> UnusableIterate(
    const MinJerkTnlp& tnlp, Ipopt::ApplicationReturnStatus ipopt_status) {
  const int status = static_cast<int>(ipopt_status);
  if (!tnlp.HasFinal() || !tnlp.Final().allFinite()) {
    return std::pair(
        ipopt_status == Ipopt::Invalid_Number_Detected ? PlanStatus::kNumericalError
                                                       : PlanStatus::kSolverFailure,
        "Ipopt returned status " + std::to_string(status) + " without a finite solution");
  }
  // A diverged time scale (the last iterate of a failed solve) is reported, not sampled: a
  // trajectory stretched 10^6 times would take gigabytes of check samples.
  const double time_scale = MinJerkProblem::TimeScale(tnlp.Final());
  if (!std::isfinite(time_scale) || time_scale > kMaxTimeScale ||
      time_scale < 1.0 / kMaxTimeScale) {
    return std::pair(PlanStatus::kSolverFailure,
                     "time scale " + std::to_string(time_scale) +
                         " of the nominal allocation is out of range (Ipopt status " +
                         std::to_string(status) + ")");
  }
  return std::nullopt;
}

}  // namespace

Ipopt::SmartPtr<Ipopt::IpoptApplication> NewPlannerIpoptApplication() {
  LinkIpoptTimerOverride();
  RegisterDenseMa27WithIpopt();
  Ipopt::SmartPtr<Ipopt::IpoptApplication> a =
      new Ipopt::IpoptApplication(/*create_console_out=*/false);
  auto opts = a->Options();
  opts->SetIntegerValue("print_level", 0);
  opts->SetStringValue("sb", "yes");
  opts->SetStringValue("linear_solver", "ma27");
  opts->SetStringValue("linear_system_scaling", "none");
  opts->SetStringValue("hessian_approximation", "exact");
  opts->SetNumericValue("ma27_la_init_factor", 1.0);
  opts->SetNumericValue("ma27_liw_init_factor", 1.0);
  // No constraints: second-order corrections never apply, their trial points only cost
  // objective evaluations (what leaving them out saves: docs/performance.md).
  opts->SetIntegerValue("max_soc", 0);
  // A Newton step that moves every variable by less than 1e-8 of max(1, |value|) (0.1 µm on a
  // waypoint 10 m from the world origin, a relative change of 1e-8 of the time scale) is taken
  // without a line search: at that resolution f(x + αd) and f(x) differ by rounding only, and the
  // line search (Ipopt's default threshold is 10 machine epsilons) would halve α many times per
  // iteration before the rounding-floor stall test ended the solve. Convergence is still
  // decided by `tol` on the gradient, so the solutions stay the same (docs/performance.md
  // measures the evaluations saved).
  opts->SetNumericValue("tiny_step_tol", 1e-8);
  // Iterative refinement of a Newton step only when its residual asks for it (Ipopt's default
  // refines every step at least once: a residual and a back-solve through its vector classes).
  // The dense LDLᵀ of this small system meets residual_ratio_max (1e-10) without it
  // (docs/performance.md measures the instructions saved and the unchanged solutions).
  opts->SetIntegerValue("min_refinement_steps", 0);
  // An empty file name: no `ipopt.opt` is read from the working directory.
  a->Initialize("");
  return a;
}

void TrajectoryOptimizerOptions::Validate(const std::string& origin) const {
  auto positive = [&](double v, const char* key) {
    if (!(v > 0.0) || !std::isfinite(v)) throw ConfigError(origin, key, "must be finite and > 0");
  };
  positive(sample_spacing, "sample_spacing");
  if (min_samples_per_piece < 1) {
    throw ConfigError(origin, "min_samples_per_piece", "must be >= 1");
  }
  if (max_samples_per_piece < min_samples_per_piece) {
    throw ConfigError(origin, "max_samples_per_piece", "must be >= min_samples_per_piece");
  }
  if (!(tolerance > 0.0) || !(tolerance <= 1e-2)) {
    throw ConfigError(origin, "tolerance", "must be in (0, 1e-2]");
  }
  if (max_iterations < 1) throw ConfigError(origin, "max_iterations", "must be >= 1");
  if (!(stall_relative_change > 0.0) || !(stall_relative_change <= 1e-3)) {
    throw ConfigError(origin, "stall_relative_change", "must be in (0, 1e-3]");
  }
  if (stall_iterations < 1) throw ConfigError(origin, "stall_iterations", "must be >= 1");
  if (!(rounding_floor > 0.0) || !(rounding_floor <= 1e-10)) {
    throw ConfigError(origin, "rounding_floor", "must be in (0, 1e-10]");
  }
  positive(check_dt, "check_dt");
  if (!(limit_tolerance >= 0.0) || !std::isfinite(limit_tolerance)) {
    throw ConfigError(origin, "limit_tolerance", "must be finite and >= 0");
  }
  if (!(collision_margin >= 0.0) || !std::isfinite(collision_margin)) {
    throw ConfigError(origin, "collision_margin", "must be finite and >= 0");
  }
  positive(collision_scale, "collision_scale");
  positive(feasibility_scale, "feasibility_scale");
}

TrajectoryOptimizer::TrajectoryOptimizer(const TrajectoryOptimizerOptions& options)
    : options_(options) {
  options_.Validate("TrajectoryOptimizerOptions");
}

std::vector<double> TrajectoryOptimizer::AllocateTime(const std::vector<Eigen::Vector3d>& path_W,
                                                      int num_pieces, double v0, double vf,
                                                      double v_max, double a_max, double braking) {
  QT_DEMAND(num_pieces >= 1 && path_W.size() >= 2, "need >= 1 piece and a path");
  QT_DEMAND(v_max > 0.0 && a_max > 0.0, "limits must be > 0");
  QT_DEMAND(braking >= 0.0, "braking must be >= 0");
  const std::vector<double> s = ArcLengths(path_W);
  const double length = s.back();
  // A start above v_max brakes down to it (braking > 0), else counts as v_max.
  const double v_brake = braking > 0.0 && v0 > v_max ? v0 : 0.0;
  v0 = std::clamp(v0, 0.0, v_max);
  vf = std::clamp(vf, 0.0, v_max);
  // Speed along the path: accelerate from v0 (or brake from v_brake), cruise at v_max,
  // decelerate to vf; a floor keeps the time finite where the profile starts or ends at rest.
  const double v_floor = 0.1 * v_max;
  auto speed = [&](double at) {
    const double up = std::sqrt(v0 * v0 + 2.0 * a_max * at);
    const double down = std::sqrt(vf * vf + 2.0 * a_max * std::max(0.0, length - at));
    if (v_brake > 0.0) {
      const double braked = std::sqrt(std::max(0.0, v_brake * v_brake - 2.0 * braking * at));
      return std::max(v_floor, std::min(std::max(v_max, braked), down));
    }
    return std::max(v_floor, std::min({v_max, up, down}));
  };
  constexpr int kSteps = 32;  // midpoint rule per piece
  std::vector<double> durations;
  durations.reserve(static_cast<std::size_t>(num_pieces));
  const double piece = length / num_pieces;
  for (int i = 0; i < num_pieces; ++i) {
    double t = 0.0;
    const double h = piece / kSteps;
    for (int k = 0; k < kSteps; ++k) t += h / speed((i + (k + 0.5) / kSteps) * piece);
    durations.push_back(std::max(t, 1e-3));
  }
  return durations;
}

PlanResult TrajectoryOptimizer::Solve(const PlanRequest& request, const DistanceField& field,
                                      const PlannerParams& params) const {
  try {
    params.Validate("PlannerParams");
  } catch (const ConfigError& e) {
    return Invalid(e.what());
  }
  return SolveValidated(request, field, params);
}

PlanResult TrajectoryOptimizer::SolveValidated(const PlanRequest& request,
                                               const DistanceField& field,
                                               const PlannerParams& params) const {
  const auto wall_start = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  };
  try {
    const Eigen::Vector3d vf =
        request.speed_scale * request.goal_v_W.value_or(Eigen::Vector3d::Zero());
    if (auto error = RequestError(request, vf)) return Invalid(std::move(*error));
    const std::vector<Eigen::Vector3d> path = PathThrough(request);
    const std::vector<double> arc = ArcLengths(path);
    const double length = arc.back();
    if (path.size() < 2 || !(length > 1e-3)) return Invalid("goal coincides with the start");

    const int n_pieces = params.n_pol;
    const std::vector<double> nominal = AllocateTime(path, n_pieces, request.v0_W.norm(), vf.norm(),
                                                     request.speed_scale * params.v_des,
                                                     params.a_max, request.braking_deceleration);
    const int samples =
        std::clamp(static_cast<int>(std::ceil(length / n_pieces / options_.sample_spacing)),
                   options_.min_samples_per_piece, options_.max_samples_per_piece);
    MinJerkBoundary boundary;
    boundary.p0_W = request.p0_W;
    boundary.v0_W = request.v0_W;
    boundary.a0_W = request.a0_W;
    boundary.pf_W = request.goal_W;
    boundary.vf_W = vf;
    const MinJerkProblem problem(boundary, nominal,
                                 std::vector<int>(static_cast<std::size_t>(n_pieces), samples),
                                 field, CostParamsFor(request, params, options_));

    Ipopt::IpoptApplication& app = ThreadApplication();
    const bool curvature = field.ProvidesCurvature();
    SetSolveOptions(app, options_, curvature);
    Ipopt::SmartPtr<MinJerkTnlp> tnlp =
        new MinJerkTnlp(problem, InitialGuess(problem, request, path, arc, nominal));
    const Ipopt::ApplicationReturnStatus ipopt_status = app.OptimizeTNLP(tnlp);

    PlanResult result;
    result.solver_status = static_cast<int>(ipopt_status);
    RecordEffort(problem, *tnlp, app, &result);
    const Eigen::VectorXd& z = tnlp->Final();
    if (tnlp->HasFinal() && z.allFinite()) {
      const PlanCostTerms* final_terms = tnlp->TermsAt(z);
      result.cost = final_terms != nullptr ? *final_terms : problem.Evaluate(z, nullptr, nullptr);
    }
    if (auto unusable = UnusableIterate(*tnlp, ipopt_status)) {
      result.status = unusable->first;
      result.message = std::move(unusable->second);
      result.solve_time_s = elapsed();
      return result;
    }
    result.trajectory = problem.ToTrajectory(z);
    Conclude(ipopt_status, curvature, Measure(request.p0_W, field, params, &result), params,
             &result);
    result.solve_time_s = elapsed();
    return result;
  } catch (const std::exception& e) {
    PlanResult r;
    r.status = PlanStatus::kSolverFailure;
    r.message = std::string("exception during solve: ") + e.what();
    r.solve_time_s = elapsed();
    return r;
  }
}

void TrajectoryOptimizer::Conclude(int ipopt_status, bool curvature, double required_clearance,
                                   const PlannerParams& params, PlanResult* result) const {
  const bool converged =
      ipopt_status == Ipopt::Solve_Succeeded || ipopt_status == Ipopt::Solved_To_Acceptable_Level;
  if (!std::isfinite(result->cost.total) || !std::isfinite(result->max_speed) ||
      ipopt_status == Ipopt::Invalid_Number_Detected) {
    result->status = PlanStatus::kNumericalError;
    result->message =
        "non-finite cost or trajectory (Ipopt status " + std::to_string(ipopt_status) + ")";
  } else if (ipopt_status == Ipopt::Maximum_Iterations_Exceeded) {
    result->status = PlanStatus::kMaxIterations;
    result->message = "Ipopt reached max_iter = " + std::to_string(options_.max_iterations);
  } else if (!converged) {
    result->status = PlanStatus::kSolverFailure;
    result->message = "Ipopt failed with status " + std::to_string(ipopt_status);
  } else if (Judge(required_clearance, params, result)) {
    result->message = ipopt_status == Ipopt::Solve_Succeeded
                          ? "converged"
                          : (curvature ? "stalled at the objective's rounding floor"
                                       : "stalled (non-smooth field)");
  }
}

double TrajectoryOptimizer::Measure(const Eigen::Vector3d& p0_W, const DistanceField& field,
                                   const PlannerParams& params, PlanResult* result) const {
  // Dense samples every check_dt and at the end. A plan keeps inflation + collision_margin from
  // every obstacle; one that starts closer than that (after a disturbance, a collision or an
  // emergency stop) must not come closer than its start, or no plan could ever leave.
  const double required_clearance =
      std::min(params.inflation + options_.collision_margin, field.Evaluate(p0_W, nullptr));
  const Trajectory& trajectory = result->trajectory;
  result->duration = trajectory.Duration();
  result->max_speed = 0.0;
  result->max_acceleration = 0.0;
  result->min_clearance = std::numeric_limits<double>::infinity();
  const auto check = [&](double t) {
    Eigen::Vector3d p;
    Eigen::Vector3d v;
    Eigen::Vector3d a;
    trajectory.State(t, &p, &v, &a);
    result->max_speed = std::max(result->max_speed, v.norm());
    result->max_acceleration = std::max(result->max_acceleration, a.norm());
    result->min_clearance = std::min(result->min_clearance, field.Evaluate(p, nullptr));
  };
  for (long k = 0; static_cast<double>(k) * options_.check_dt < result->duration; ++k) {
    check(static_cast<double>(k) * options_.check_dt);
  }
  check(result->duration);
  return required_clearance;
}

bool TrajectoryOptimizer::Judge(double required_clearance, const PlannerParams& params,
                                PlanResult* result) const {
  if (result->min_clearance < required_clearance) {
    result->status = PlanStatus::kCollision;
    result->message = "trajectory passes " + std::to_string(result->min_clearance) +
                      " m from an obstacle (needs " + std::to_string(required_clearance) + " m)";
    return false;
  }
  if (result->max_speed > params.v_des * (1.0 + options_.limit_tolerance) ||
      result->max_acceleration > params.a_max * (1.0 + options_.limit_tolerance)) {
    result->status = PlanStatus::kDynamicsViolated;
    result->message = "max |v| " + std::to_string(result->max_speed) + " m/s, max |a| " +
                      std::to_string(result->max_acceleration) + " m/s^2 exceed the limits";
    return false;
  }
  result->status = PlanStatus::kSuccess;
  result->message.clear();
  return true;
}

void TrajectoryOptimizer::Check(const Eigen::Vector3d& p0_W, const DistanceField& field,
                                const PlannerParams& params, PlanResult* result) const {
  QT_DEMAND(result != nullptr && !result->trajectory.Empty(), "Check needs a trajectory");
  const double required_clearance = Measure(p0_W, field, params, result);
  if (!std::isfinite(result->max_speed) || !std::isfinite(result->max_acceleration)) {
    result->status = PlanStatus::kNumericalError;
    result->message = "non-finite trajectory";
    return;
  }
  (void)Judge(required_clearance, params, result);
}

}  // namespace quadtune::planning
