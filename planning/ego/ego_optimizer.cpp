#include "quadtune/planning/ego/ego_optimizer.hpp"

#include <lbfgs.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "quadtune/common/error.hpp"
#include "quadtune/planning/quintic.hpp"

namespace quadtune::planning {

void EgoOptions::Validate(const std::string& origin) const {
  CheckInRange(segments_per_pol, Range::Closed(1, 16), origin, "segments_per_pol");
  CheckInRange(max_rebounds, Range::Closed(0, 20), origin, "max_rebounds");
  CheckInRange(max_reallocations, Range::Closed(0, 10), origin, "max_reallocations");
  CheckInRange(lbfgs_memory, Range::Closed(1, 64), origin, "lbfgs_memory");
  CheckInRange(lbfgs_max_iterations, Range::Closed(1, 10000), origin, "lbfgs_max_iterations");
  CheckInRange(lbfgs_epsilon, {0.0, 1.0, false, false}, origin, "lbfgs_epsilon");
  CheckInRange(lbfgs_delta, {0.0, 1.0, true, false}, origin, "lbfgs_delta");
  CheckInRange(fitness_along_weight, {0.0, 1.0, false, true}, origin, "fitness_along_weight");
  CheckInRange(fitness_weight, Range::Positive(), origin, "fitness_weight");
  CheckInRange(check_dt, Range::Positive(), origin, "check_dt");
  CheckInRange(clearance_dt, Range::Positive(), origin, "clearance_dt");
  CheckInRange(limit_tolerance, Range::NonNegative(), origin, "limit_tolerance");
  CheckInRange(gamma_search_margin, Range::Closed(0.0, 50.0), origin, "gamma_search_margin");
  CheckInRange(gamma_max_expansions, Range::Closed(1, 100000000), origin, "gamma_max_expansions");
}

Eigen::Matrix3d BoundaryControlPoints(const Eigen::Vector3d& p, const Eigen::Vector3d& v,
                                      const Eigen::Vector3d& a, double dt) {
  // p = (Q0 + 4Q1 + Q2)/6, v = (Q2 − Q0)/(2dt), a = (Q0 − 2Q1 + Q2)/dt².
  const Eigen::Vector3d q1 = p - a * (dt * dt / 6.0);
  const Eigen::Vector3d sum = a * (dt * dt) + 2.0 * q1;  // Q0 + Q2
  const Eigen::Vector3d diff = 2.0 * dt * v;             // Q2 − Q0
  Eigen::Matrix3d out;
  out.col(0) = 0.5 * (sum - diff);
  out.col(1) = q1;
  out.col(2) = 0.5 * (sum + diff);
  return out;
}

Trajectory BsplineToTrajectory(const ControlPoints& q, double dt) {
  QT_DEMAND(q.cols() >= 4 && dt > 0.0, "BsplineToTrajectory: needs >= 4 control points, dt > 0");
  const int spans = static_cast<int>(q.cols()) - 3;
  std::vector<double> durations(static_cast<std::size_t>(spans), dt);
  std::vector<Trajectory::Coefficients> coefficients;
  coefficients.reserve(durations.size());
  const double s1 = 1.0 / dt, s2 = s1 * s1, s3 = s2 * s1;
  for (int k = 0; k < spans; ++k) {
    const auto q0 = q.col(k), q1 = q.col(k + 1), q2 = q.col(k + 2), q3 = q.col(k + 3);
    Trajectory::Coefficients c = Trajectory::Coefficients::Zero();
    c.col(0) = (q0 + 4.0 * q1 + q2) / 6.0;
    c.col(1) = (q2 - q0) * (0.5 * s1);
    c.col(2) = (q0 - 2.0 * q1 + q2) * (0.5 * s2);
    c.col(3) = (q3 - q0 + 3.0 * (q1 - q2)) * (s3 / 6.0);
    coefficients.push_back(c);
  }
  return Trajectory(std::move(durations), std::move(coefficients));
}

namespace {

// The point of polyline `path` where the plane through `q` with normal `n` first meets it
// (nearest vertex when it never does).
Eigen::Vector3d PlaneHit(const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& q,
                         const Eigen::Vector3d& n) {
  for (std::size_t k = 0; k + 1 < path.size(); ++k) {
    const double a = (path[k] - q).dot(n);
    const double b = (path[k + 1] - q).dot(n);
    if (a == 0.0) return path[k];
    if ((a < 0.0) != (b < 0.0)) return path[k] + (a / (a - b)) * (path[k + 1] - path[k]);
  }
  std::size_t best = 0;
  for (std::size_t k = 1; k < path.size(); ++k) {
    if ((path[k] - q).squaredNorm() < (path[best] - q).squaredNorm()) best = k;
  }
  return path[best];
}

}  // namespace

std::vector<RepulsionPair> MakeRepulsionPairs(const LocalMap& map, const ControlPoints& q,
                                              const std::vector<bool>& colliding,
                                              PathSearcher& searcher, long* expansions) {
  const int n = static_cast<int>(q.cols());
  QT_DEMAND(static_cast<int>(colliding.size()) == n, "MakeRepulsionPairs: flag per point");
  std::vector<RepulsionPair> pairs;
  const double step = 0.5 * map.resolution();
  int i = 0;
  while (i < n) {
    if (!colliding[static_cast<std::size_t>(i)]) {
      ++i;
      continue;
    }
    int last = i;
    while (last + 1 < n && colliding[static_cast<std::size_t>(last + 1)]) ++last;
    // Free ends of the run: the nearest control points outside it that are free.
    int a = i - 1, b = last + 1;
    while (a > 0 && map.IsOccupied(Eigen::Vector3d(q.col(a)))) --a;
    while (b < n - 1 && map.IsOccupied(Eigen::Vector3d(q.col(b)))) ++b;
    a = std::max(a, 0);
    b = std::min(b, n - 1);
    const PathSearchResult gamma = searcher.Search(map, q.col(a), q.col(b));
    if (expansions != nullptr) *expansions += gamma.expansions;
    if (gamma.ok() && gamma.path.size() >= 2) {
      for (int j = i; j <= last; ++j) {
        const Eigen::Vector3d qj = q.col(j);
        Eigen::Vector3d tangent = q.col(std::min(j + 1, n - 1)) - q.col(std::max(j - 1, 0));
        if (tangent.norm() < 1e-9) continue;
        tangent.normalize();
        const Eigen::Vector3d r = PlaneHit(gamma.path, qj, tangent) - qj;
        const double length = r.norm();
        if (length < 1e-9) continue;
        const Eigen::Vector3d dir = r / length;
        bool seen_obstacle = false;
        for (double s = 0.0; s <= length + 1e-12; s += step) {
          const Eigen::Vector3d x = qj + s * dir;
          const bool occupied = map.IsOccupied(x);
          if (occupied) {
            seen_obstacle = true;
          } else if (seen_obstacle) {
            pairs.push_back({j, x, dir});
            break;
          }
        }
      }
    }
    i = last + 1;
  }
  return pairs;
}

// ---------------------------------------------------------------------------------------------
// EgoCost

EgoCost::EgoCost(ControlPoints q, double dt, std::vector<RepulsionPair> pairs,
                 const PlannerParams& params)
    : q_(std::move(q)), dt_(dt), pairs_(std::move(pairs)), params_(params) {
  QT_DEMAND(q_.cols() >= 7 && dt_ > 0.0, "EgoCost: needs >= 7 control points and dt > 0");
}

void EgoCost::SetFitness(Eigen::Matrix3Xd targets, Eigen::Matrix3Xd tangents, double along_weight,
                         double weight) {
  QT_DEMAND(targets.cols() == q_.cols() - 4 && tangents.cols() == targets.cols(),
            "EgoCost::SetFitness: one target per inner knot");
  fit_targets_ = std::move(targets);
  fit_tangents_ = std::move(tangents);
  fit_along_ = along_weight;
  fit_weight_ = weight;
}

Eigen::VectorXd EgoCost::Variables() const {
  const int m = static_cast<int>(q_.cols()) - 6;
  Eigen::VectorXd x(3 * m);
  for (int j = 0; j < m; ++j) x.segment<3>(3 * j) = q_.col(j + 3);
  return x;
}

ControlPoints EgoCost::WithVariables(const double* x) const {
  ControlPoints q = q_;
  const int m = static_cast<int>(q_.cols()) - 6;
  for (int j = 0; j < m; ++j) q.col(j + 3) = Eigen::Vector3d(x[3 * j], x[3 * j + 1], x[3 * j + 2]);
  return q;
}

namespace {

// Penalty F(c) of the collision term and its derivative.
double CollisionPenalty(double c, double sf, double* dF) {
  if (c <= 0.0) {
    *dF = 0.0;
    return 0.0;
  }
  if (c <= sf) {
    *dF = 3.0 * c * c;
    return c * c * c;
  }
  *dF = 6.0 * sf * c - 3.0 * sf * sf;
  return 3.0 * sf * c * c - 3.0 * sf * sf * c + sf * sf * sf;
}

// (|x| − limit)₊² and its gradient with respect to x (added to *g scaled by `scale`).
double ExcessPenalty(const Eigen::Vector3d& x, double limit, double scale, Eigen::Vector3d* g) {
  const double norm = x.norm();
  if (norm <= limit) {
    g->setZero();
    return 0.0;
  }
  const double e = norm - limit;
  *g = (2.0 * e * scale / norm) * x;
  return e * e;
}

}  // namespace

double EgoCost::Evaluate(const double* x, double* grad, EgoCostTerms* terms) const {
  const ControlPoints q = WithVariables(x);
  const int n = static_cast<int>(q.cols());
  Eigen::Matrix3Xd g = Eigen::Matrix3Xd::Zero(3, n);
  const double ws = params_.w_smooth, wc = params_.w_col, wd = params_.w_dyn;
  EgoCostTerms t;

  // Smoothness: second and third differences of the control polygon.
  for (int i = 0; i + 2 < n; ++i) {
    const Eigen::Vector3d d2 = q.col(i + 2) - 2.0 * q.col(i + 1) + q.col(i);
    t.smoothness += d2.squaredNorm();
    const Eigen::Vector3d gd = 2.0 * ws * d2;
    g.col(i) += gd;
    g.col(i + 1) -= 2.0 * gd;
    g.col(i + 2) += gd;
  }
  for (int i = 0; i + 3 < n; ++i) {
    const Eigen::Vector3d d3 = q.col(i + 3) - 3.0 * q.col(i + 2) + 3.0 * q.col(i + 1) - q.col(i);
    t.smoothness += d3.squaredNorm();
    const Eigen::Vector3d gd = 2.0 * ws * d3;
    g.col(i) -= gd;
    g.col(i + 1) += 3.0 * gd;
    g.col(i + 2) -= 3.0 * gd;
    g.col(i + 3) += gd;
  }

  // Collision: repulsion pairs.
  const double sf = params_.clearance;
  for (const RepulsionPair& pr : pairs_) {
    const double c = sf - (q.col(pr.index) - pr.p).dot(pr.v);
    double dF = 0.0;
    t.collision += CollisionPenalty(c, sf, &dF);
    g.col(pr.index) -= wc * dF * pr.v;
  }

  // Feasibility: velocity and acceleration control points beyond the limits.
  const double inv_dt = 1.0 / dt_, inv_dt2 = inv_dt * inv_dt;
  Eigen::Vector3d gv;
  for (int i = 0; i + 1 < n; ++i) {
    const Eigen::Vector3d v = (q.col(i + 1) - q.col(i)) * inv_dt;
    t.feasibility += ExcessPenalty(v, params_.v_des, wd * inv_dt, &gv);
    g.col(i) -= gv;
    g.col(i + 1) += gv;
  }
  for (int i = 0; i + 2 < n; ++i) {
    const Eigen::Vector3d a = (q.col(i + 2) - 2.0 * q.col(i + 1) + q.col(i)) * inv_dt2;
    t.feasibility += ExcessPenalty(a, params_.a_max, wd * inv_dt2, &gv);
    g.col(i) += gv;
    g.col(i + 1) -= 2.0 * gv;
    g.col(i + 2) += gv;
  }

  // Fitness of the refit: anisotropic distance of the knots to the previous curve.
  if (fit_weight_ > 0.0) {
    for (int j = 1; j + 3 < n; ++j) {
      const Eigen::Vector3d knot = (q.col(j - 1) + 4.0 * q.col(j) + q.col(j + 1)) / 6.0;
      const Eigen::Vector3d e = knot - fit_targets_.col(j - 1);
      const Eigen::Vector3d tan = fit_tangents_.col(j - 1);
      const double along = e.dot(tan);
      const Eigen::Vector3d across = e - along * tan;
      t.fitness += across.squaredNorm() + fit_along_ * along * along;
      const Eigen::Vector3d ge = fit_weight_ * 2.0 * (across + fit_along_ * along * tan);
      g.col(j - 1) += ge / 6.0;
      g.col(j) += ge * (4.0 / 6.0);
      g.col(j + 1) += ge / 6.0;
    }
  }

  t.total = ws * t.smoothness + wc * t.collision + wd * t.feasibility + fit_weight_ * t.fitness;
  if (grad != nullptr) {
    for (int j = 0; j + 6 < n; ++j) {
      for (int k = 0; k < 3; ++k) grad[3 * j + k] = g(k, j + 3);
    }
  }
  if (terms != nullptr) *terms = t;
  return t.total;
}

// ---------------------------------------------------------------------------------------------
// SolveEgo

namespace {

// libLBFGS callback context.
struct LbfgsContext {
  const EgoCost* cost;
  int n;          // real variables (the rest of the padded vector is ignored)
  int evaluations = 0;
};

lbfgsfloatval_t EvaluateCallback(void* instance, const lbfgsfloatval_t* x, lbfgsfloatval_t* g,
                                 const int n_padded, const lbfgsfloatval_t /*step*/) {
  auto* ctx = static_cast<LbfgsContext*>(instance);
  ++ctx->evaluations;
  for (int i = ctx->n; i < n_padded; ++i) g[i] = 0.0;
  return ctx->cost->Evaluate(x, g);
}

// Minimises `cost` from its stored control points; returns the optimised control points.
ControlPoints Minimise(const EgoCost& cost, const EgoOptions& o, EgoSolveStats* stats) {
  const int n = cost.NumVariables();
  // libLBFGS built with SSE needs a multiple of 8 variables: pad with inert ones.
  const int padded = (n + 7) / 8 * 8;
  lbfgsfloatval_t* x = lbfgs_malloc(padded);
  QT_DEMAND(x != nullptr, "lbfgs_malloc failed");
  const Eigen::VectorXd x0 = cost.Variables();
  for (int i = 0; i < padded; ++i) x[i] = i < n ? x0[i] : 0.0;
  lbfgs_parameter_t param;
  lbfgs_parameter_init(&param);
  param.m = o.lbfgs_memory;
  param.max_iterations = o.lbfgs_max_iterations;
  param.epsilon = o.lbfgs_epsilon;
  param.past = o.lbfgs_delta > 0.0 ? 3 : 0;
  param.delta = o.lbfgs_delta;
  LbfgsContext ctx{&cost, n};
  lbfgsfloatval_t fx = 0.0;
  const int status = lbfgs(padded, x, &fx, EvaluateCallback, nullptr, &ctx, &param);
  ControlPoints q = cost.WithVariables(x);
  lbfgs_free(x);
  ++stats->lbfgs_runs;
  stats->evaluations += ctx.evaluations;
  stats->lbfgs_status = status;
  return q;
}

// Control points whose cell is occupied (inflated), among the free ones [3, N−4]; and those
// supporting a span whose curve enters an occupied cell (sampled at resolution/2 spacing).
std::vector<bool> CollidingPoints(const LocalMap& map, const ControlPoints& q, double dt) {
  const int n = static_cast<int>(q.cols());
  std::vector<bool> flags(static_cast<std::size_t>(n), false);
  for (int i = 3; i + 3 < n; ++i) flags[static_cast<std::size_t>(i)] = map.IsOccupied(q.col(i));
  const Trajectory curve = BsplineToTrajectory(q, dt);
  for (int k = 0; k + 3 < n; ++k) {
    const double length = (q.col(k + 2) - q.col(k + 1)).norm();
    const int samples = std::max(2, static_cast<int>(std::ceil(length / (0.5 * map.resolution()))));
    for (int s = 0; s <= samples; ++s) {
      const Eigen::Vector3d p = curve.Position((k + static_cast<double>(s) / samples) * dt);
      if (map.IsOccupied(p)) {
        for (int j = k + 1; j <= k + 2; ++j) {
          if (j >= 3 && j + 3 < n) flags[static_cast<std::size_t>(j)] = true;
        }
        break;
      }
    }
  }
  return flags;
}

// Largest |V_i| and |A_i| over the control polygon.
void PolygonLimits(const ControlPoints& q, double dt, double* v_max, double* a_max) {
  *v_max = 0.0;
  *a_max = 0.0;
  for (int i = 0; i + 1 < q.cols(); ++i) *v_max = std::max(*v_max, (q.col(i + 1) - q.col(i)).norm() / dt);
  for (int i = 0; i + 2 < q.cols(); ++i) {
    *a_max = std::max(*a_max, (q.col(i + 2) - 2.0 * q.col(i + 1) + q.col(i)).norm() / (dt * dt));
  }
}

// Acceptance check: samples, limits, clearance. Returns the number of samples taken.
int CheckCurve(const LocalMap& map, const PlannerParams& params, const EgoOptions& o,
               PlanResult* result) {
  const Trajectory& traj = result->trajectory;
  const double T = traj.Duration();
  result->duration = T;
  result->max_speed = 0.0;
  result->max_acceleration = 0.0;
  bool inside_start = true;  // still in the inflated region the plan started in
  bool collision = false;
  int samples = 0;
  for (double t = 0.0;; t += o.check_dt) {
    const double tc = std::min(t, T);
    Eigen::Vector3d p, v, a;
    traj.State(tc, &p, &v, &a);
    ++samples;
    if (!p.allFinite() || !v.allFinite() || !a.allFinite()) {
      result->status = PlanStatus::kNumericalError;
      result->message = "non-finite trajectory";
      return samples;
    }
    result->max_speed = std::max(result->max_speed, v.norm());
    result->max_acceleration = std::max(result->max_acceleration, a.norm());
    const bool occupied = map.IsOccupied(p);
    if (!occupied) inside_start = false;
    if (occupied && !inside_start) collision = true;
    if (tc >= T) break;
  }
  result->min_clearance = params.clearance;
  for (double t = 0.0;; t += o.clearance_dt) {
    const double tc = std::min(t, T);
    result->min_clearance =
        std::min(result->min_clearance, map.RawClearance(traj.Position(tc), result->min_clearance));
    ++samples;
    if (tc >= T) break;
  }
  if (collision) {
    result->status = PlanStatus::kCollision;
    result->message = "the curve enters an inflated obstacle";
  } else if (result->max_speed > params.v_des * (1.0 + o.limit_tolerance) ||
             result->max_acceleration > params.a_max * (1.0 + o.limit_tolerance)) {
    result->status = PlanStatus::kDynamicsViolated;
    result->message = "over the velocity or acceleration limit";
  } else {
    result->status = PlanStatus::kSuccess;
    result->message.clear();
  }
  return samples;
}

double PathLength(const std::vector<Eigen::Vector3d>& path) {
  double length = 0.0;
  for (std::size_t k = 1; k < path.size(); ++k) length += (path[k] - path[k - 1]).norm();
  return length;
}

// Initial control points on the front-end path and their knot span.
ControlPoints InitialControlPoints(const PlanningQuery& query, const PlannerParams& params,
                                   const EgoOptions& o, double time_scale, double* dt) {
  std::vector<Eigen::Vector3d> path = query.initial_path_W;
  if (path.size() < 2) path = {query.p0_W, query.goal_W};
  const double length = PathLength(path);
  const double spacing = params.h_pl / (params.n_pol * o.segments_per_pol);
  const int spans = std::max(4, static_cast<int>(std::ceil(length / spacing - 1e-9)));
  // Time: the path at v_des, or a rest-to-rest profile at a_max where that is slower.
  const double total = std::max(length / params.v_des, 2.0 * std::sqrt(length / params.a_max));
  *dt = std::max(total, 1e-3) * time_scale / spans;
  const std::vector<Eigen::Vector3d> points = ResampleByArcLength(path, spans);
  ControlPoints q(3, spans + 3);
  q.col(0) = points.front();
  for (int j = 0; j <= spans; ++j) q.col(j + 1) = points[static_cast<std::size_t>(j)];
  q.col(spans + 2) = points.back();
  return q;
}

void FixBoundary(const PlanningQuery& query, double dt, ControlPoints* q) {
  const int n = static_cast<int>(q->cols());
  q->leftCols<3>() = BoundaryControlPoints(query.p0_W, query.v0_W, query.a0_W, dt);
  q->middleCols<3>(n - 3) =
      BoundaryControlPoints(query.goal_W, query.goal_v_W, Eigen::Vector3d::Zero(), dt);
}

// The curve of `q` at its inner knots: positions (`targets`) and unit tangents (+x where it
// stands still), the fit a time reallocation keeps.
void InnerKnotStates(const ControlPoints& q, double dt, Eigen::Matrix3Xd* targets,
                     Eigen::Matrix3Xd* tangents) {
  const Trajectory old = BsplineToTrajectory(q, dt);
  const int n = static_cast<int>(q.cols());
  targets->resize(3, n - 4);
  tangents->resize(3, n - 4);
  for (int j = 1; j + 3 < n; ++j) {
    Eigen::Vector3d p, v, a;
    old.State(j * dt, &p, &v, &a);
    targets->col(j - 1) = p;
    const double speed = v.norm();
    tangents->col(j - 1) = speed > 1e-9 ? Eigen::Vector3d(v / speed) : Eigen::Vector3d::UnitX();
  }
}

// The collision, feasibility and total cost of the final control points into `result->cost`.
void SetFinalCostTerms(const ControlPoints& q, double dt, const std::vector<RepulsionPair>& pairs,
                       const PlannerParams& params, PlanResult* result) {
  EgoCost final_cost(q, dt, pairs, params);
  const Eigen::VectorXd x = final_cost.Variables();
  EgoCostTerms terms;
  final_cost.Evaluate(x.data(), nullptr, &terms);
  result->cost.collision = terms.collision;
  result->cost.feasibility = terms.feasibility;
  result->cost.total = terms.total;
}

}  // namespace

PlanResult SolveEgo(const PlanningQuery& query, const PlannerParams& params,
                    const EgoOptions& o, double time_scale, EgoSolveStats* stats_out, ControlPoints* control_points,
                    double* knot_span) {
  const auto wall_start = std::chrono::steady_clock::now();
  PlanResult result;
  EgoSolveStats stats;
  auto finish = [&](PlanResult r, int check_samples) {
    r.compute_units = 1.0 + static_cast<double>(stats.evaluations) * r.num_variables / 1200.0 +
                      static_cast<double>(stats.expansions) / 2000.0 + 0.02 * check_samples;
    r.iterations = stats.lbfgs_runs;
    r.function_evaluations = stats.evaluations;
    r.gradient_evaluations = stats.evaluations;
    r.solve_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    if (stats_out != nullptr) *stats_out = stats;
    return r;
  };
  if (query.occupancy == nullptr) {
    result.status = PlanStatus::kInvalidInput;
    result.message = "the query carries no occupancy snapshot (QuerySnapshot::kOccupancy)";
    return finish(std::move(result), 0);
  }
  const LocalMap& map = *query.occupancy;
  double dt = 0.0;
  ControlPoints q = InitialControlPoints(query, params, o, time_scale, &dt);
  FixBoundary(query, dt, &q);
  result.num_variables = 3 * (static_cast<int>(q.cols()) - 6);

  PathSearchOptions search;
  search.search_margin = o.gamma_search_margin;
  search.max_expansions = o.gamma_max_expansions;
  PathSearcher searcher(search);
  std::vector<RepulsionPair> pairs;
  std::vector<bool> has_pairs(static_cast<std::size_t>(q.cols()), false);

  // Adds pairs for colliding control points that have none; true when any was added.
  auto add_pairs = [&](const ControlPoints& current) {
    std::vector<bool> flags = CollidingPoints(map, current, dt);
    bool any = false;
    for (std::size_t i = 0; i < flags.size(); ++i) {
      if (has_pairs[i]) flags[i] = false;
      any = any || flags[i];
    }
    if (!any) return false;
    std::vector<RepulsionPair> fresh = MakeRepulsionPairs(map, current, flags, searcher,
                                                          &stats.expansions);
    for (const auto& p : fresh) has_pairs[static_cast<std::size_t>(p.index)] = true;
    pairs.insert(pairs.end(), fresh.begin(), fresh.end());
    return !fresh.empty();
  };

  // Solve, then rebound rounds.
  auto solve_with_rebound = [&]() {
    add_pairs(q);
    for (int round = 0;; ++round) {
      EgoCost cost(q, dt, pairs, params);
      q = Minimise(cost, o, &stats);
      if (!q.allFinite()) return false;
      if (round >= o.max_rebounds || !add_pairs(q)) return true;
      ++stats.rebounds;
    }
  };
  bool finite = solve_with_rebound();

  // Time reallocation.
  for (int round = 0; finite && round < o.max_reallocations; ++round) {
    double vm = 0.0, am = 0.0;
    PolygonLimits(q, dt, &vm, &am);
    const double ratio = std::max(vm / params.v_des, std::sqrt(am / params.a_max));
    if (ratio <= 1.0 + o.limit_tolerance) break;
    ++stats.reallocations;
    Eigen::Matrix3Xd targets, tangents;
    InnerKnotStates(q, dt, &targets, &tangents);
    dt *= ratio;
    FixBoundary(query, dt, &q);
    EgoCost refit(q, dt, pairs, params);
    refit.SetFitness(targets, tangents, o.fitness_along_weight, o.fitness_weight);
    q = Minimise(refit, o, &stats);
    finite = q.allFinite() && solve_with_rebound();
  }
  stats.pairs = static_cast<int>(pairs.size());
  if (control_points != nullptr) *control_points = q;
  if (knot_span != nullptr) *knot_span = dt;
  if (!finite) {
    result.status = PlanStatus::kNumericalError;
    result.message = "non-finite control points";
    return finish(std::move(result), 0);
  }
  result.trajectory = BsplineToTrajectory(q, dt);
  result.cost.jerk = result.trajectory.JerkEnergy();
  SetFinalCostTerms(q, dt, pairs, params, &result);
  const int samples = CheckCurve(map, params, o, &result);
  return finish(std::move(result), samples);
}

// ---------------------------------------------------------------------------------------------
// EgoBackend

EgoBackend::EgoBackend(const EgoOptions& options) : options_(options) { options_.Validate(); }

PlanOutcome EgoBackend::Solve(const PlanningQuery& query, const PlannerParams& params,
                              const LocalPlannerOptions& options) const {
  PlanOutcome out;
  const int attempts = std::max(1, params.max_attempts);
  for (int k = 0; k < attempts; ++k) {
    const double time_scale = 1.0 / std::pow(options.retry_slowdown, k);
    PlanResult r = SolveEgo(query, params, options_, time_scale);
    out.attempts = k + 1;
    out.solve_time_s += r.solve_time_s;
    out.compute_units += r.compute_units;
    const bool ok = r.Ok();
    const bool retry = r.status != PlanStatus::kInvalidInput;
    out.result = std::move(r);
    out.failed_attempts = ok ? k : k + 1;
    if (ok || !retry) break;
  }
  return out;
}

std::optional<PlanResult> EgoBackend::Fallback(const PlanningQuery& query,
                                               const PlannerParams& params, double speed) const {
  QT_DEMAND(speed > 0.0 && std::isfinite(speed), "stop-and-go speed must be positive");
  if (!options_.stop_and_go) return std::nullopt;
  PlanResult result;
  std::optional<Trajectory> trajectory =
      StopAndGo(query.initial_path_W, query.p0_W, query.v0_W, query.a0_W,
                std::min(speed, params.v_des), params.a_max);
  if (query.occupancy == nullptr || !trajectory) {
    result.status = PlanStatus::kInvalidInput;
    result.message = query.occupancy == nullptr ? "stop-and-go: the query holds no occupancy map"
                                                : "stop-and-go: the front end's path has no length";
    return result;
  }
  result.trajectory = std::move(*trajectory);
  result.cost.jerk = result.trajectory.JerkEnergy();
  (void)CheckCurve(*query.occupancy, params, options_, &result);
  return result;
}

}  // namespace quadtune::planning
