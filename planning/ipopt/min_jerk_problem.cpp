#include "quadtune/planning/ipopt/min_jerk_problem.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "quadtune/common/error.hpp"
#include "quadtune/planning/ipopt/transposed_product.hpp"

namespace quadtune::planning {
namespace {

// β_d(s): row of d-th derivative of the monomial basis 1, s, ..., s^5 at s.
Eigen::Matrix<double, 1, 6> BasisRow(double s, int d) {
  Eigen::Matrix<double, 1, 6> row = Eigen::Matrix<double, 1, 6>::Zero();
  for (int k = d; k < 6; ++k) {
    double factor = 1.0;
    for (int m = 0; m < d; ++m) factor *= static_cast<double>(k - m);
    row(k) = factor * std::pow(s, k - d);
  }
  return row;
}

// Q with cᵀ Q c = ∫_0^T |c'''(s)|² ds for one axis of a quintic.
Eigen::Matrix<double, 6, 6> JerkGram(double t) {
  const double t2 = t * t;
  const double t3 = t2 * t;
  const double t4 = t3 * t;
  const double t5 = t4 * t;
  Eigen::Matrix<double, 6, 6> q = Eigen::Matrix<double, 6, 6>::Zero();
  q(3, 3) = 36.0 * t;
  q(3, 4) = q(4, 3) = 72.0 * t2;
  q(3, 5) = q(5, 3) = 120.0 * t3;
  q(4, 4) = 192.0 * t3;
  q(4, 5) = q(5, 4) = 360.0 * t4;
  q(5, 5) = 720.0 * t5;
  return q;
}

// Throws std::invalid_argument unless every piece has a finite duration > 0 and a sample count
// >= 1 and the weights and limits are in range.
void CheckProblemInputs(const std::vector<double>& nominal,
                        const std::vector<int>& samples_per_piece,
                        const MinJerkCostParams& params) {
  if (nominal.empty() || samples_per_piece.size() != nominal.size()) {
    throw std::invalid_argument("MinJerkProblem: need >= 1 piece and one sample count per piece");
  }
  for (std::size_t i = 0; i < nominal.size(); ++i) {
    if (!std::isfinite(nominal[i]) || nominal[i] <= 0.0) {
      throw std::invalid_argument("MinJerkProblem: nominal duration " + std::to_string(i) +
                                  " must be finite and > 0");
    }
    if (samples_per_piece[i] < 1) {
      throw std::invalid_argument("MinJerkProblem: samples_per_piece must be >= 1");
    }
  }
  if (!(params.clearance > 0.0) || !(params.v_max > 0.0) || !(params.a_max > 0.0) ||
      !(params.w_smooth > 0.0) || params.w_col < 0.0 || params.w_dyn < 0.0 || params.w_time < 0.0 ||
      !(params.collision_scale > 0.0) || !(params.feasibility_scale > 0.0) ||
      !(params.brake_from_speed >= 0.0) || !(params.braking_deceleration >= 0.0) ||
      !std::isfinite(params.brake_from_speed) || !std::isfinite(params.braking_deceleration)) {
    throw std::invalid_argument("MinJerkProblem: weights/limits out of range");
  }
}

// The map K from the boundary vector b (start p, v, a; inner waypoints; end p, v, a) to the
// coefficients c = K b of every piece (6 per piece, one axis), for nominal piece durations.
Eigen::MatrixXd CoefficientMap(const std::vector<double>& nominal, int nb) {
  const int n = static_cast<int>(nominal.size());
  // Min-jerk system M c = E b (per axis): boundary p, v, a at both ends; at each inner knot the
  // waypoint on both sides and continuity of derivatives 1..4.
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(6 * n, 6 * n);
  Eigen::MatrixXd e = Eigen::MatrixXd::Zero(6 * n, nb);
  for (int d = 0; d < 3; ++d) {
    m.block(d, 0, 1, 6) = BasisRow(0.0, d);
    e(d, d) = 1.0;
  }
  for (int i = 0; i + 1 < n; ++i) {
    const int r = 3 + 6 * i;
    const double t = nominal[static_cast<std::size_t>(i)];
    m.block(r, 6 * i, 1, 6) = BasisRow(t, 0);
    e(r, 3 + i) = 1.0;
    m.block(r + 1, 6 * (i + 1), 1, 6) = BasisRow(0.0, 0);
    e(r + 1, 3 + i) = 1.0;
    for (int d = 1; d <= 4; ++d) {
      m.block(r + 1 + d, 6 * i, 1, 6) = BasisRow(t, d);
      m.block(r + 1 + d, 6 * (i + 1), 1, 6) = -BasisRow(0.0, d);
    }
  }
  const double t_last = nominal.back();
  for (int d = 0; d < 3; ++d) {
    m.block(6 * n - 3 + d, 6 * (n - 1), 1, 6) = BasisRow(t_last, d);
    e(6 * n - 3 + d, n + 2 + d) = 1.0;
  }
  return m.partialPivLu().solve(e);
}

}  // namespace

MinJerkCostParams MinJerkCostParams::FromPlannerParams(const PlannerParams& params) {
  MinJerkCostParams c;
  c.w_smooth = params.w_smooth;
  c.w_col = params.w_col;
  c.w_dyn = params.w_dyn;
  c.w_time = params.w_time;
  c.clearance = params.clearance;
  c.v_max = params.v_des;
  c.a_max = params.a_max;
  return c;
}

MinJerkProblem::MinJerkProblem(const MinJerkBoundary& boundary,
                               std::vector<double> nominal_durations,
                               std::vector<int> samples_per_piece, const DistanceField& field,
                               const MinJerkCostParams& params)
    : boundary_(boundary),
      nominal_(std::move(nominal_durations)),
      field_(&field),
      params_(params),
      num_pieces_(static_cast<int>(nominal_.size())) {
  CheckProblemInputs(nominal_, samples_per_piece, params_);

  const int n = num_pieces_;
  const int nb = BoundarySize();
  coeff_map_ = CoefficientMap(nominal_, nb);
  for (double t : nominal_) sum_nominal_ += t;
  inv_limit_sq_[1] = 1.0 / (params_.v_max * params_.v_max);
  inv_limit_sq_[2] = 1.0 / (params_.a_max * params_.a_max);

  jerk_hess_ = Eigen::MatrixXd::Zero(nb, nb);
  for (int i = 0; i < n; ++i) {
    const Eigen::MatrixXd ki = coeff_map_.block(6 * i, 0, 6, nb);
    jerk_hess_ += ki.transpose() * JerkGram(nominal_[static_cast<std::size_t>(i)]) * ki;
  }
  jerk_hess_ = 0.5 * (jerk_hess_ + jerk_hess_.transpose()).eval();
  if (detail::TransposedProductApplies(nb, nb, 3)) {
    const int stride = detail::TransposedProductStride(nb);
    jerk_hess_rows_.assign(static_cast<std::size_t>(nb) * static_cast<std::size_t>(stride), 0.0);
    for (int k = 0; k < nb; ++k) {  // row k of l = column k of H̄ (l(k, i) = H̄(i, k))
      for (int i = 0; i < nb; ++i) {
        jerk_hess_rows_[static_cast<std::size_t>(k * stride + i)] = jerk_hess_(i, k);
      }
    }
  }

  int total_samples = 0;
  for (int k : samples_per_piece) total_samples += k;
  for (auto& rows : sample_rows_) rows.resize(total_samples, nb);
  sample_piece_.reserve(static_cast<std::size_t>(total_samples));
  const bool braking =
      params_.braking_deceleration > 0.0 && params_.brake_from_speed > params_.v_max;
  if (braking) inv_speed_limit_sq_.reserve(static_cast<std::size_t>(total_samples));
  int j = 0;
  double piece_start = 0.0;  // nominal time of the piece's start (s)
  for (int i = 0; i < n; ++i) {
    const int count = samples_per_piece[static_cast<std::size_t>(i)];
    const Eigen::MatrixXd ki = coeff_map_.block(6 * i, 0, 6, nb);
    for (int k = 1; k <= count; ++k) {
      const double s = nominal_[static_cast<std::size_t>(i)] * static_cast<double>(k) /
                       static_cast<double>(count);
      for (int d = 0; d < 3; ++d) sample_rows_[d].row(j) = BasisRow(s, d) * ki;
      sample_piece_.push_back(i);
      if (braking) {
        const double limit =
            std::max(params_.v_max,
                     params_.brake_from_speed - params_.braking_deceleration * (piece_start + s));
        inv_speed_limit_sq_.push_back(1.0 / (limit * limit));
      }
      ++j;
    }
    piece_start += nominal_[static_cast<std::size_t>(i)];
  }
}

Eigen::VectorXd MinJerkProblem::Pack(const std::vector<Eigen::Vector3d>& inner_waypoints_W,
                                     double time_scale) const {
  const int m = num_pieces_ - 1;
  QT_DEMAND(static_cast<int>(inner_waypoints_W.size()) == m, "need N-1 inner waypoints");
  QT_DEMAND(time_scale > 0.0, "time scale must be > 0");
  Eigen::VectorXd z(NumVariables());
  for (int a = 0; a < 3; ++a) {
    for (int i = 0; i < m; ++i) z(a * m + i) = inner_waypoints_W[static_cast<std::size_t>(i)](a);
  }
  z(NumVariables() - 1) = std::log(time_scale);
  return z;
}

std::vector<Eigen::Vector3d> MinJerkProblem::InnerWaypoints(const Eigen::VectorXd& z) const {
  const int m = num_pieces_ - 1;
  std::vector<Eigen::Vector3d> q(static_cast<std::size_t>(m));
  for (int i = 0; i < m; ++i) {
    for (int a = 0; a < 3; ++a) q[static_cast<std::size_t>(i)](a) = z(a * m + i);
  }
  return q;
}

double MinJerkProblem::TimeScale(const Eigen::VectorXd& z) { return std::exp(z(z.size() - 1)); }

void MinJerkProblem::BoundaryVectors(const Eigen::VectorXd& z, Eigen::MatrixXd* b) const {
  const Eigen::Vector3d& origin = boundary_.p0_W;
  const int m = num_pieces_ - 1;
  const int nb = BoundarySize();
  const double tau = std::exp(z(NumVariables() - 1));
  const double tau2 = tau * tau;
  b->setZero(nb, 3);
  for (int a = 0; a < 3; ++a) {
    (*b)(0, a) = 0.0;  // p0, relative to itself
    (*b)(1, a) = tau * boundary_.v0_W(a);
    (*b)(2, a) = tau2 * boundary_.a0_W(a);
    for (int i = 0; i < m; ++i) (*b)(3 + i, a) = z(a * m + i) - origin(a);
    (*b)(nb - 3, a) = boundary_.pf_W(a) - origin(a);
    (*b)(nb - 2, a) = tau * boundary_.vf_W(a);
    (*b)(nb - 1, a) = tau2 * boundary_.af_W(a);
  }
}

namespace {

// Per-thread scratch of MinJerkProblem::Evaluate (sized on first use, reused afterwards: the
// Ipopt callbacks then run without heap allocations). Holds no state between calls.
// A sample whose penalty is active: its derivative coefficients (see Evaluate).
struct ActiveSample {
  int row = 0;
  Eigen::Vector3d grad;  // τ^-d wγ
  Eigen::Vector3d rho;   // τ^-d (wΓ r_ρ − d wγ)
  Eigen::Matrix3d hess;  // τ^-2d wΓ
};

struct EvaluateScratch {
  Eigen::MatrixXd db;
  Eigen::MatrixXd ddb;
  Eigen::MatrixXd hb;
  Eigen::MatrixXd hdb;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rows;  // S_d by rows
  std::vector<ActiveSample> active;
  Eigen::MatrixXd v;                 // active rows of S_d, inner-waypoint columns (active × m)
  Eigen::MatrixXd coef;              // per active sample, 3 coefficients
  Eigen::MatrixXd vt_coef;           // vᵀ coef (m × 3)
  Eigen::MatrixXd weighted;          // diag(c) v
  std::vector<double> vr;            // v by rows, padded (AddTransposedProduct)
  std::vector<double> wr;            // diag(c) v by rows, padded
  std::vector<double> cr;            // coef by rows
  std::vector<double> b_rows;        // b by rows (EvaluateValue)
  MinJerkProblem::ValueCache value;  // Evaluate's value pass when the caller gives no cache
};

EvaluateScratch& Scratch() {
  thread_local EvaluateScratch scratch;
  return scratch;
}

// The rows of ∂b/∂ρ and ∂²b/∂ρ² that can be nonzero (RateDerivatives): the velocity and the
// acceleration of both ends. Every position row is independent of ρ, so products with those
// matrices need only these rows.
std::array<int, 4> RateRows(int nb) { return {1, 2, nb - 2, nb - 1}; }

// ∂b/∂ρ and ∂²b/∂ρ² (ddb may be null) from the boundary vectors b: d/dρ of τ^k x is k τ^k x,
// the second derivative k² τ^k x, in the rows RateRows; every other row is zero.
void RateDerivatives(const Eigen::MatrixXd& b, Eigen::MatrixXd* db, Eigen::MatrixXd* ddb) {
  const Eigen::Index nb = b.rows();
  db->setZero(nb, 3);
  if (ddb != nullptr) ddb->setZero(nb, 3);
  for (int a = 0; a < 3; ++a) {
    (*db)(1, a) = b(1, a);
    (*db)(2, a) = 2.0 * b(2, a);
    (*db)(nb - 2, a) = b(nb - 2, a);
    (*db)(nb - 1, a) = 2.0 * b(nb - 1, a);
    if (ddb != nullptr) {
      (*ddb)(1, a) = b(1, a);
      (*ddb)(2, a) = 4.0 * b(2, a);
      (*ddb)(nb - 2, a) = b(nb - 2, a);
      (*ddb)(nb - 1, a) = 4.0 * b(nb - 1, a);
    }
  }
}

// *out = m · x for an x whose nonzero rows are all in `nz`: the sum of four outer products,
// added in that order, in one pass per column.
void TimesRate(const Eigen::MatrixXd& m, const Eigen::MatrixXd& x, const std::array<int, 4>& nz,
               Eigen::MatrixXd* out) {
  out->resize(m.rows(), x.cols());
  for (Eigen::Index a = 0; a < x.cols(); ++a) {
    out->col(a) = m.col(nz[0]) * x(nz[0], a) + m.col(nz[1]) * x(nz[1], a) +
                  m.col(nz[2]) * x(nz[2], a) + m.col(nz[3]) * x(nz[3], a);
  }
}

// Row j of m · x for an x whose nonzero rows are all in `nz`: that row of TimesRate's result
// (the same four products, added in the same order).
inline Eigen::Vector3d RateRow(const Eigen::MatrixXd& m, int j, const Eigen::MatrixXd& x,
                               const std::array<int, 4>& nz) {
  const double* mj = m.data() + j;
  const Eigen::Index ld = m.rows();
  const double m0 = mj[nz[0] * ld], m1 = mj[nz[1] * ld], m2 = mj[nz[2] * ld], m3 = mj[nz[3] * ld];
  Eigen::Vector3d out;
  for (int a = 0; a < 3; ++a) {
    const double* xa = x.data() + a * x.rows();
    out(a) = m0 * xa[nz[0]] + m1 * xa[nz[1]] + m2 * xa[nz[2]] + m3 * xa[nz[3]];
  }
  return out;
}

// *w = s · b for a b of three columns (the states of every sample at once). Each entry sums its
// nb products in index order from zero, as Eigen's blocked matrix product does, without that
// product's packing of the constant s on every call (s is stored by column, and four samples
// are summed at a time). Below Eigen's size threshold for its coefficient-wise product, whose sums
// run in another order, that product is used (on s by rows, as it was stored before); either way
// the values are those of Eigen's `s * b`.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__SANITIZE_THREAD__)
__attribute__((target_clones("avx2", "default")))
#endif
void SamplesTimes(const Eigen::MatrixXd& s, const Eigen::MatrixXd& b, Eigen::MatrixXd* w,
                  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>* rows) {
  const Eigen::Index ns = s.rows();
  const Eigen::Index nb = s.cols();
  if (nb + ns + b.cols() < EIGEN_GEMM_TO_COEFFBASED_THRESHOLD || b.cols() != 3) {
    *rows = s;
    w->noalias() = *rows * b;
    return;
  }
  w->resize(ns, 3);
  double* w0 = w->col(0).data();
  double* w1 = w->col(1).data();
  double* w2 = w->col(2).data();
  const double* bk = b.data();  // column a at bk + a·nb
  // Blocks of four samples, their twelve running sums in registers (GCC vectors: two SSE2
  // registers each, one AVX register in the AVX2 clone; lane-wise products and sums either way).
  typedef double Lanes4 __attribute__((vector_size(32)));
  constexpr Eigen::Index kBlock = 4;
  Eigen::Index j0 = 0;
  for (; j0 + kBlock <= ns; j0 += kBlock) {
    Lanes4 a0 = {0.0, 0.0, 0.0, 0.0};
    Lanes4 a1 = a0;
    Lanes4 a2 = a0;
    for (Eigen::Index k = 0; k < nb; ++k) {
      Lanes4 sk;
      std::memcpy(&sk, s.data() + k * ns + j0, sizeof sk);
      a0 += sk * bk[k];
      a1 += sk * bk[nb + k];
      a2 += sk * bk[2 * nb + k];
    }
    std::memcpy(w0 + j0, &a0, sizeof a0);
    std::memcpy(w1 + j0, &a1, sizeof a1);
    std::memcpy(w2 + j0, &a2, sizeof a2);
  }
  for (; j0 < ns; ++j0) {
    double a0 = 0.0, a1 = 0.0, a2 = 0.0;
    for (Eigen::Index k = 0; k < nb; ++k) {
      const double sk = s(j0, k);
      a0 += sk * bk[k];
      a1 += sk * bk[nb + k];
      a2 += sk * bk[2 * nb + k];
    }
    w0[j0] = a0;
    w1[j0] = a1;
    w2[j0] = a2;
  }
}

}  // namespace

bool MinJerkProblem::ValueCache::Holds(const MinJerkProblem* problem,
                                       const Eigen::VectorXd& z) const {
  return valid_ && owner_ == problem && z_.size() == z.size() &&
         std::memcmp(z_.data(), z.data(), sizeof(double) * static_cast<std::size_t>(z.size())) == 0;
}

void MinJerkProblem::EvaluateValue(const Eigen::VectorXd& z, ValueCache* vc) const {
  vc->valid_ = false;
  vc->owner_ = this;
  vc->z_ = z;
  const double rho = z(NumVariables() - 1);
  const double tau = std::exp(rho);
  const Eigen::Vector3d& origin = boundary_.p0_W;
  BoundaryVectors(z, &vc->b_);
  const Eigen::MatrixXd& b = vc->b_;
  PlanCostTerms& terms = vc->terms_;
  terms = PlanCostTerms{};

  // ---- jerk energy: τ^-5 Σ_a b_aᵀ H̄ b_a ----
  if (!jerk_hess_rows_.empty()) {  // H̄ b = lᵀ b with the bits of Eigen's product
    const int nb = BoundarySize();
    std::vector<double>& b_rows = Scratch().b_rows;
    b_rows.resize(static_cast<std::size_t>(nb) * 3);
    for (int k = 0; k < nb; ++k) {
      for (int a = 0; a < 3; ++a) b_rows[static_cast<std::size_t>(3 * k + a)] = b(k, a);
    }
    vc->hb_.setZero(nb, 3);
    detail::AddTransposedProduct(nb, nb, 3, jerk_hess_rows_.data(),
                                 detail::TransposedProductStride(nb), b_rows.data(), 3,
                                 vc->hb_.data(), nb, /*lower_only=*/false);
  } else {
    vc->hb_.noalias() = jerk_hess_ * b;
  }
  vc->g0_ = (b.array() * vc->hb_.array()).sum();
  terms.jerk = std::exp(-5.0 * rho) * vc->g0_;

  // ---- time stretch: ΣT̄ ρ² (ρ = ln τ; zero at the nominal allocation) ----
  terms.time = sum_nominal_ * rho * rho;

  // ---- sampled penalties: the states of every sample at once (W = S_d b), then the samples
  // whose penalty is active ----
  const double inv_c = 1.0 / params_.clearance;
  const double inv_tau_pow[3] = {1.0, 1.0 / tau, 1.0 / (tau * tau)};
  const int ns = NumSamples();
  for (int d = 0; d < 3; ++d) {
    SamplesTimes(sample_rows_[d], b, &vc->w_[d], &Scratch().rows);
    const Eigen::MatrixXd& ws = vc->w_[d];
    std::vector<int>& active = vc->active_[d];
    active.clear();
    const double scale = inv_tau_pow[d];
    for (int j = 0; j < ns; ++j) {
      const Eigen::Vector3d w = ws.row(j).transpose();
      const Eigen::Vector3d r = d == 0 ? Eigen::Vector3d(w + origin) : Eigen::Vector3d(scale * w);
      if (d == 0) {
        // Samples certainly beyond the clearance add nothing: the field may skip them.
        double dist = 0.0;
        if (!field_->EvaluateWithHessianBelow(r, params_.clearance, &dist, nullptr, nullptr)) {
          continue;
        }
        const double e = (params_.clearance - dist) * inv_c;
        if (!(e > 0.0)) {
          if (!std::isfinite(dist)) terms.collision = std::numeric_limits<double>::quiet_NaN();
          continue;
        }
        // ψ = κ e³, e = (C − d)/C.
        terms.collision += params_.collision_scale * e * e * e;
      } else {
        double inv_l = 0.0;
        const double viol = RateViolation(d, j, r, &inv_l);
        if (!(viol > 0.0)) continue;
        terms.feasibility += params_.feasibility_scale * viol * viol * viol;
      }
      active.push_back(j);
    }
  }
  terms.total = params_.w_smooth * terms.jerk + params_.w_col * terms.collision +
                params_.w_dyn * terms.feasibility + params_.w_time * terms.time;
  vc->valid_ = true;
}

// The derivative steps of Evaluate(): each adds its part of ∇f (and of ∇²f's lower triangle,
// when wanted) at one z, in the order Evaluate calls them (the sums keep their order, so the
// bits do not depend on how the steps are cut).
class MinJerkProblem::GradientPass {
 public:
  GradientPass(const MinJerkProblem& problem, const ValueCache& vc, EvaluateScratch& ws,
               const Eigen::VectorXd& z, Eigen::VectorXd& g, Eigen::MatrixXd* hess)
      : p_(problem),
        vc_(vc),
        ws_(ws),
        g_(g),
        hess_(hess),
        want_hess_(hess != nullptr),
        n_(problem.NumVariables()),
        m_(problem.num_pieces_ - 1),
        ir_(n_ - 1),
        rho_(z(ir_)),
        tau_(std::exp(rho_)),
        rate_rows_(RateRows(problem.BoundarySize())) {
    RateDerivatives(vc.b_, &ws.db, want_hess_ ? &ws.ddb : nullptr);
  }

  // Jerk energy: τ^-5 Σ_a b_aᵀ H̄ b_a.
  void AddJerk() {
    const Eigen::MatrixXd& db = ws_.db;
    const Eigen::MatrixXd& ddb = ws_.ddb;
    const double w_s = p_.params_.w_smooth;
    const double e5 = std::exp(-5.0 * rho_);
    const Eigen::MatrixXd& hb = vc_.hb_;
    const double g0 = vc_.g0_;
    const double g1 = 2.0 * (db.array() * hb.array()).sum();
    for (int a = 0; a < 3; ++a) {
      for (int i = 0; i < m_; ++i) g_(a * m_ + i) += w_s * e5 * 2.0 * hb(3 + i, a);
    }
    g_(ir_) += w_s * e5 * (g1 - 5.0 * g0);
    if (!want_hess_) return;
    TimesRate(p_.jerk_hess_, db, rate_rows_, &ws_.hdb);
    const Eigen::MatrixXd& hdb = ws_.hdb;
    const double g2 = 2.0 * ((db.array() * hdb.array()).sum() + (ddb.array() * hb.array()).sum());
    for (int a = 0; a < 3; ++a) {
      hess_->block(a * m_, a * m_, m_, m_) += (w_s * e5 * 2.0) * p_.jerk_hess_.block(3, 3, m_, m_);
      for (int i = 0; i < m_; ++i) {
        (*hess_)(ir_, a * m_ + i) += w_s * e5 * (2.0 * hdb(3 + i, a) - 10.0 * hb(3 + i, a));
      }
    }
    (*hess_)(ir_, ir_) += w_s * e5 * (g2 - 10.0 * g1 + 25.0 * g0);
  }

  // Time stretch: ΣT̄ ρ².
  void AddTimeStretch() {
    g_(ir_) += p_.params_.w_time * 2.0 * p_.sum_nominal_ * rho_;
    if (want_hess_) (*hess_)(ir_, ir_) += p_.params_.w_time * 2.0 * p_.sum_nominal_;
  }

  // The sampled penalty of derivative order d (0: collision, 1: speed, 2: acceleration), its
  // active samples only.
  void AddSampledPenalty(int d) {
    const double weights[3] = {p_.params_.w_col, p_.params_.w_dyn, p_.params_.w_dyn};
    const double weight = weights[d];
    if (weight == 0.0) return;
    CollectActiveSamples(d, weight);
    if (ws_.active.empty()) return;
    AddActiveProducts(d);
  }

 private:
  // ψ's derivatives at active sample j of order d (at r): ∂ψ/∂r into *gamma and, when the
  // Hessian is wanted, ∂²ψ/∂r² into *big_gamma. False: the sample adds nothing here.
  bool PenaltyDerivatives(int d, int j, const Eigen::Vector3d& r, Eigen::Vector3d* gamma,
                          Eigen::Matrix3d* big_gamma) const {
    const MinJerkCostParams& params = p_.params_;
    if (d == 0) {
      const double inv_c = 1.0 / params.clearance;
      Eigen::Vector3d grad_d;
      Eigen::Matrix3d hess_d;
      double dist = 0.0;
      // Active at this z: the field evaluates it (the same distance as EvaluateValue's).
      if (!p_.field_->EvaluateWithHessianBelow(r, params.clearance, &dist, &grad_d,
                                               want_hess_ ? &hess_d : nullptr)) {
        return false;
      }
      const double e = (params.clearance - dist) * inv_c;
      if (!(e > 0.0)) return false;
      // ∂ψ/∂r = −3κe²/C ∇d, ∂²ψ/∂r² = 6κe/C² ∇d∇dᵀ − 3κe²/C ∇²d.
      const double k = params.collision_scale;
      *gamma = (-3.0 * k * e * e * inv_c) * grad_d;
      if (want_hess_) {
        *big_gamma = (6.0 * k * e * inv_c * inv_c) * (grad_d * grad_d.transpose()) -
                     (3.0 * k * e * e * inv_c) * hess_d;
      }
      return true;
    }
    double inv_l = 0.0;
    const double viol = p_.RateViolation(d, j, r, &inv_l);
    if (!(viol > 0.0)) return false;
    const double k = params.feasibility_scale;
    const Eigen::Vector3d dviol = 2.0 * inv_l * r;
    *gamma = (3.0 * k * viol * viol) * dviol;
    if (want_hess_) {
      *big_gamma = (6.0 * k * viol) * (dviol * dviol.transpose()) +
                   (6.0 * k * viol * viol * inv_l) * Eigen::Matrix3d::Identity();
    }
    return true;
  }

  // Per active sample: its row index, the q-gradient coefficients wγ τ^-d, the ρ-row
  // coefficients t τ^-d and the six distinct entries of wΓ τ^-2d (for the q–q blocks), into
  // ws_.active; its ρ entries straight into ∇f and ∇²f.
  void CollectActiveSamples(int d, double weight) {
    const double inv_tau_pow[3] = {1.0, 1.0 / tau_, 1.0 / (tau_ * tau_)};
    const auto& rows = p_.sample_rows_[d];
    const Eigen::MatrixXd& wd = vc_.w_[d];
    const double scale = inv_tau_pow[d];
    const double dd = static_cast<double>(d);
    ws_.active.clear();
    for (const int j : vc_.active_[d]) {
      const Eigen::Vector3d w = wd.row(j).transpose();
      const Eigen::Vector3d r =
          d == 0 ? Eigen::Vector3d(w + p_.boundary_.p0_W) : Eigen::Vector3d(scale * w);
      Eigen::Vector3d gamma;      // ∂ψ/∂r
      Eigen::Matrix3d big_gamma;  // ∂²ψ/∂r²
      if (!PenaltyDerivatives(d, j, r, &gamma, &big_gamma)) continue;
      // r = τ^-d S_j b: ∂r/∂q_a(i) = τ^-d row(3+i) e_a, ∂r/∂ρ = τ^-d (S_j b' − d S_j b).
      const Eigen::Vector3d w1 = RateRow(rows, j, ws_.db, rate_rows_);
      const Eigen::Vector3d r_rho = scale * (w1 - dd * w);
      const Eigen::Vector3d wg = weight * gamma;
      g_(ir_) += wg.dot(r_rho);
      ActiveSample sample;
      sample.row = j;
      sample.grad = scale * wg;
      if (want_hess_) {
        const Eigen::Matrix3d wgg = weight * big_gamma;
        // ρ row: ∂²ψ/∂ρ∂q = (wΓ r_ρ)_a v_i + wγ_a ∂²r_a/∂ρ∂q_a(i), the latter = −d v_i.
        sample.rho = scale * (wgg * r_rho - dd * wg);
        const Eigen::Vector3d w2 = RateRow(rows, j, ws_.ddb, rate_rows_);
        const Eigen::Vector3d r_rhorho = scale * (w2 - 2.0 * dd * w1 + dd * dd * w);
        (*hess_)(ir_, ir_) += r_rho.dot(wgg * r_rho) + wg.dot(r_rhorho);
        sample.hess = (scale * scale) * wgg;
      }
      ws_.active.push_back(sample);
    }
  }

  // v_j = τ^-d S_j(3..3+m): gather the active rows, then the q-gradient, the ρ row and the
  // q–q blocks are small matrix products: g_qa += Vᵀ c_a, H_ρq_a += Vᵀ t_a,
  // H_qa,qb += Vᵀ diag(wΓ_ab) V (lower block triangle; the mirror fills the rest). Each runs in
  // AddTransposedProduct where that gives the bits of Eigen's product, else in Eigen's.
  void AddActiveProducts(int d) {
    const auto& rows = p_.sample_rows_[d];
    const int na = static_cast<int>(ws_.active.size());
    const int m = m_;
    const bool own_3 = detail::TransposedProductApplies(na, m, 3);
    const bool own_m = want_hess_ && detail::TransposedProductApplies(na, m, m);
    const int mp = detail::TransposedProductStride(m);
    if (own_3 || own_m) {  // V by rows, padded to mp columns
      ws_.vr.assign(static_cast<std::size_t>(na) * static_cast<std::size_t>(mp), 0.0);
      for (int i = 0; i < na; ++i) {
        const int row = ws_.active[static_cast<std::size_t>(i)].row;
        for (int c = 0; c < m; ++c) ws_.vr[static_cast<std::size_t>(i * mp + c)] = rows(row, 3 + c);
      }
    }
    if (!own_3 || (want_hess_ && !own_m)) {  // V by columns, for Eigen's products
      ws_.v.resize(na, m);
      for (int i = 0; i < na; ++i) {
        ws_.v.row(i) = rows.row(ws_.active[static_cast<std::size_t>(i)].row).segment(3, m);
      }
    }
    VTransposeTimes(own_3, mp,
                    [](const ActiveSample& s) -> const Eigen::Vector3d& { return s.grad; });
    for (int a = 0; a < 3; ++a) g_.segment(a * m, m) += ws_.vt_coef.col(a);
    if (!want_hess_) return;
    VTransposeTimes(own_3, mp,
                    [](const ActiveSample& s) -> const Eigen::Vector3d& { return s.rho; });
    for (int a = 0; a < 3; ++a) hess_->row(ir_).segment(a * m, m) += ws_.vt_coef.col(a).transpose();
    for (int a = 0; a < 3; ++a) {
      for (int bb = 0; bb <= a; ++bb) AddQqBlock(own_m, mp, a, bb);
    }
  }

  // ws_.vt_coef = Vᵀ C (m × 3), C's row i the coefficients `coef(active[i])`.
  template <typename Coef>
  void VTransposeTimes(bool own_3, int mp, Coef coef) {
    const int na = static_cast<int>(ws_.active.size());
    if (own_3) {
      ws_.cr.resize(static_cast<std::size_t>(na) * 3);
      for (int i = 0; i < na; ++i) {
        const Eigen::Vector3d& c = coef(ws_.active[static_cast<std::size_t>(i)]);
        for (int a = 0; a < 3; ++a) ws_.cr[static_cast<std::size_t>(3 * i + a)] = c(a);
      }
      ws_.vt_coef.setZero(m_, 3);  // as Eigen's product: zero, then add
      detail::AddTransposedProduct(na, m_, 3, ws_.vr.data(), mp, ws_.cr.data(), 3,
                                   ws_.vt_coef.data(), m_, /*lower_only=*/false);
    } else {
      ws_.coef.resize(na, 3);
      for (int i = 0; i < na; ++i) {
        ws_.coef.row(i) = coef(ws_.active[static_cast<std::size_t>(i)]).transpose();
      }
      ws_.vt_coef.noalias() = ws_.v.transpose() * ws_.coef;
    }
  }

  // H_qa,qb += Vᵀ diag(wΓ_ab) V.
  void AddQqBlock(bool own_m, int mp, int a, int bb) {
    const int na = static_cast<int>(ws_.active.size());
    const int m = m_;
    if (own_m) {
      ws_.wr.resize(ws_.vr.size());
      for (int i = 0; i < na; ++i) {
        const double h = ws_.active[static_cast<std::size_t>(i)].hess(a, bb);
        for (int c = 0; c < mp; ++c) {
          const auto k = static_cast<std::size_t>(i * mp + c);
          ws_.wr[k] = h * ws_.vr[k];
        }
      }
      detail::AddTransposedProduct(na, m, m, ws_.wr.data(), mp, ws_.vr.data(), mp,
                                   &(*hess_)(a * m, bb * m), n_, /*lower_only=*/a == bb);
    } else {
      ws_.weighted.resize(na, m);
      for (int i = 0; i < na; ++i) {
        ws_.weighted.row(i) = ws_.active[static_cast<std::size_t>(i)].hess(a, bb) * ws_.v.row(i);
      }
      hess_->block(a * m, bb * m, m, m).noalias() += ws_.weighted.transpose() * ws_.v;
    }
  }

  const MinJerkProblem& p_;
  const ValueCache& vc_;
  EvaluateScratch& ws_;
  Eigen::VectorXd& g_;
  Eigen::MatrixXd* hess_;
  bool want_hess_;
  int n_;
  int m_;   // inner waypoints per axis
  int ir_;  // index of ρ
  double rho_;
  double tau_;
  std::array<int, 4> rate_rows_;
};

PlanCostTerms MinJerkProblem::Evaluate(const Eigen::VectorXd& z, Eigen::VectorXd* grad,
                                       Eigen::MatrixXd* hess, ValueCache* cache) const {
  const int n = NumVariables();
  QT_DEMAND(z.size() == n, "wrong number of variables");
  const bool want_grad = grad != nullptr || hess != nullptr;
  EvaluateScratch& ws = Scratch();
  // The value and the active samples: from the cache when it holds this z, else computed (into
  // the cache, or into scratch).
  ValueCache& vc = cache != nullptr ? *cache : ws.value;
  if (cache == nullptr || !vc.Holds(this, z)) EvaluateValue(z, &vc);
  const PlanCostTerms terms = vc.terms_;
  if (!want_grad) return terms;

  Eigen::VectorXd g_local;
  Eigen::VectorXd& g = grad != nullptr ? *grad : g_local;
  g.setZero(n);
  // The Hessian is accumulated in its lower triangle and mirrored at the end.
  if (hess != nullptr) hess->setZero(n, n);
  GradientPass pass(*this, vc, ws, z, g, hess);
  pass.AddJerk();
  pass.AddTimeStretch();
  for (int d = 0; d < 3; ++d) pass.AddSampledPenalty(d);
  if (hess != nullptr) hess->triangularView<Eigen::StrictlyUpper>() = hess->transpose();
  return terms;
}

Trajectory MinJerkProblem::ToTrajectory(const Eigen::VectorXd& z) const {
  Eigen::MatrixXd b;
  BoundaryVectors(z, &b);
  const double tau = TimeScale(z);
  Eigen::MatrixXd c = coeff_map_ * b;  // 6N × 3, normalised time, positions relative to p0
  for (int i = 0; i < num_pieces_; ++i) c.row(6 * i) += boundary_.p0_W.transpose();
  std::vector<double> durations;
  std::vector<Trajectory::Coefficients> coeffs;
  durations.reserve(static_cast<std::size_t>(num_pieces_));
  coeffs.reserve(static_cast<std::size_t>(num_pieces_));
  for (int i = 0; i < num_pieces_; ++i) {
    Trajectory::Coefficients ci;
    double inv_tau_k = 1.0;
    for (int k = 0; k < 6; ++k) {
      ci.col(k) = c.row(6 * i + k).transpose() * inv_tau_k;
      inv_tau_k /= tau;
    }
    coeffs.push_back(ci);
    durations.push_back(tau * nominal_[static_cast<std::size_t>(i)]);
  }
  return Trajectory(std::move(durations), std::move(coeffs));
}

}  // namespace quadtune::planning
