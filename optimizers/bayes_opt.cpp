#include "quadtune/optimizers/bayes_opt.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <stdexcept>
#include <string>

#include "quadtune/common/error.hpp"
#include "quadtune/optimizers/design.hpp"
#include "quadtune/optimizers/local_minimizer.hpp"
#include "state_util.hpp"

namespace quadtune::optimizers {
namespace {

/// ln h(z) and d ln h / dz for h(z) = z Φ(z) + φ(z); asymptotic series below z = −6.
void LogH(double z, double* log_h, double* dlog_h) {
  constexpr double kLogSqrt2Pi = 0.91893853320467274178;
  if (z > -6.0) {
    const double cdf = 0.5 * std::erfc(-z / std::numbers::sqrt2);
    const double pdf = std::exp(-0.5 * z * z - kLogSqrt2Pi);
    const double h = std::max(z * cdf + pdf, 1e-300);
    *log_h = std::log(h);
    *dlog_h = cdf / h;
    return;
  }
  const double t = -z;
  const double t2 = 1.0 / (t * t);
  // Mills ratio R = Φ(z)/φ(z) and q = h/φ = 1 + zR, both as asymptotic series in 1/t².
  const double r = (1.0 / t) * (1.0 - t2 * (1.0 - 3.0 * t2 * (1.0 - 5.0 * t2 * (1.0 - 7.0 * t2))));
  const double q = t2 * (1.0 - 3.0 * t2 * (1.0 - 5.0 * t2 * (1.0 - 7.0 * t2)));
  *log_h = -0.5 * z * z - kLogSqrt2Pi + std::log(q);
  *dlog_h = r / q;
}

/// ln EI in standardised units from the posterior mean and variance.
double LogEi(double incumbent, double xi, double mean, double variance) {
  const double sigma = std::sqrt(variance);
  const double z = (incumbent - mean - xi) / sigma;
  double lh = 0.0;
  double dlh = 0.0;
  LogH(z, &lh, &dlh);
  return std::log(sigma) + lh;
}

}  // namespace

const Fields<MovingBoundsOptions>& MovingBoundsFields() {
  static const Fields<MovingBoundsOptions> fields =
      Fields<MovingBoundsOptions>()
          .Flag("enabled", &MovingBoundsOptions::enabled,
                "moving damped bounds (paper Sec. III-E); a `moving_bounds` map without this key "
                "turns them on")
          .Number("damping", &MovingBoundsOptions::damping, Range::OpenUnit(), "λ_b")
          .Number("half_width", &MovingBoundsOptions::half_width, Range{0.0, 1.0, true, false},
                  "r_b, fraction of each parameter's unit range");
  return fields;
}

const Fields<BayesOptOptions>& BayesOptFields() {
  using O = BayesOptOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Choice("kernel", &O::kernel, "kernel of the Gaussian-process surrogate")
          .Integer("initial_design_size", &O::initial_design_size, Range::Closed(0, 1e6),
                   "points before the model is used")
          .Choice("initial_design", &O::initial_design, "how the initial design is drawn")
          .Choice("batch_strategy", &O::batch_strategy,
                  "how pending points in a batch are fantasised")
          .Choice("transform", &O::transform,
                  "what the surrogate models: `none`, the values told; `log`, their logarithm "
                  "(values must be > 0): a rare failure scored `failure_value` then weighs as a "
                  "ratio, not as a difference of seconds")
          .Number("exploration", &O::exploration, Range::NonNegative(),
                  "ξ in expected improvement (standardised units)")
          .Integer("acquisition_pool", &O::acquisition_pool, Range::Closed(10, 1e7),
                   "pool points scored per batch member")
          .Number("local_pool_fraction", &O::local_pool_fraction, Range{0.0, 1.0, false, true},
                  "share of the pool around the incumbent")
          .Integer("acquisition_starts", &O::acquisition_starts, Range::Closed(0, 1e4),
                   "local refinements per batch member")
          .Integer("acquisition_iterations", &O::acquisition_iterations, Range::Closed(1, 1e5),
                   "L-BFGS iterations per refinement")
          .Integer("refit_every", &O::refit_every, Range::Closed(1, 1e6),
                   "results between hyperparameter refits")
          .Integer("hyper_restarts", &O::hyper_restarts, Range::Closed(0, 1e3),
                   "random restarts on a restart refit")
          .Integer("restart_period", &O::restart_period, Range::Closed(1, 1e6),
                   "every n-th refit (and the first) restarts")
          .Flag("fit_hyperparameters", &O::fit_hyperparameters, "false: keep `gp.initial_*`")
          .Number("default_noise_variance", &O::default_noise_variance, Range::NonNegative(),
                  "σ₀² when a result carries none (objective units²)")
          .Number("discount", &O::discount, Range{0.0, 1.0, true, false},
                  "λ_d: noise of old observations is divided by λ_d^n_d, n_d counting changes of "
                  "the flying θ_s; 1: off")
          .Number("noise_growth", &O::noise_growth, Range::NonNegative(),
                  "relative noise growth per unit of age")
          .Custom(
              {"moving_bounds", "map", "see below", "",
               "moving damped bounds (paper Sec. III-E), see below"},
              [](const YamlMap& map, O& o) {
                if (!map.Has("moving_bounds")) return;
                o.moving_bounds.enabled = true;  // unless the map says otherwise
                MovingBoundsFields().Read(map.Map("moving_bounds"), o.moving_bounds);
              },
              [](YAML::Emitter& out, const O& o) {
                out << YAML::Key << "moving_bounds" << YAML::Value;
                MovingBoundsFields().Write(out, o.moving_bounds);
              })
          .Nested("gp", &O::gp, GpFields(), "surrogate bounds and fit settings, see below")
          .Integer("seed", &O::seed, Range::NonNegative(),
                   "seed (an experiment derives one per trial)");
  return fields;
}

void BayesOptOptions::Validate(const std::string& file, const std::string& prefix) const {
  BayesOptFields().Check(*this, file, prefix);
  MovingBoundsFields().Check(moving_bounds, file, prefix + "moving_bounds.");
  gp.Validate(file, prefix + "gp.");
}

BayesOptOptions BayesOptOptions::FromYaml(const YamlMap& map) {
  const BayesOptOptions o = BayesOptFields().Read(map);
  o.gp.Validate(map.file(), map.KeyPath("gp."));
  return o;
}

namespace {
BayesOpt::Model MakeModel(KernelChoice kernel, int dim, const GaussianProcessOptions& gp) {
  if (kernel == KernelChoice::kMatern52) return GaussianProcess<Matern52Kernel>(dim, gp);
  return GaussianProcess<SquaredExponentialKernel>(dim, gp);
}
}  // namespace

BayesOpt::BayesOpt(ParameterSpace space, BayesOptOptions options)
    : space_(std::move(space)),
      options_(options),
      rng_(DeriveSeed(options.seed, {0xB0})),
      model_(GaussianProcess<Matern52Kernel>(1)) {
  if (space_.Empty()) throw ConfigError("", "parameters", "the parameter space must not be empty");
  options_.Validate();
  model_ = MakeModel(options_.kernel, space_.Dim(), options_.gp);
  unit_lower_ = Eigen::VectorXd::Zero(space_.Dim());
  unit_upper_ = Eigen::VectorXd::Ones(space_.Dim());
}

double BayesOpt::NoiseMultiplier(const Observation& o) const {
  return (1.0 + options_.noise_growth * o.age) / std::pow(options_.discount, o.discount_count);
}

double BayesOpt::ObservationNoiseVariance(std::size_t j) const {
  const Observation& o = observations_.at(j);
  return NoiseMultiplier(o) * o.noise_variance;
}

int BayesOpt::ObservationDiscountCount(std::size_t j) const { return observations_.at(j).discount_count; }

void BayesOpt::NotifyContextChanged() {
  for (auto& o : observations_) ++o.discount_count;
  if (!observations_.empty() && options_.discount < 1.0) ++data_version_;
}

void BayesOpt::AdvanceAge(double amount) {
  if (!(amount >= 0.0 && std::isfinite(amount))) {
    throw std::invalid_argument("BayesOpt::AdvanceAge: amount must be finite and >= 0, got " + std::to_string(amount));
  }
  for (auto& o : observations_) o.age += amount;
  if (!observations_.empty() && options_.noise_growth > 0.0 && amount > 0.0) ++data_version_;
}

void BayesOpt::SetBounds(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper) {
  const int d = space_.Dim();
  if (lower.size() != d || upper.size() != d) {
    throw std::invalid_argument("BayesOpt::SetBounds: expected vectors of size " + std::to_string(d));
  }
  for (int i = 0; i < d; ++i) {
    const Parameter& p = space_.At(i);
    if (!(lower[i] >= p.lower && upper[i] <= p.upper && lower[i] <= upper[i])) {
      throw std::invalid_argument("BayesOpt::SetBounds: parameter '" + p.name + "': need " +
                                  std::to_string(p.lower) + " <= lower <= upper <= " + std::to_string(p.upper));
    }
  }
  Eigen::VectorXd lo = space_.ToUnit(lower);
  Eigen::VectorXd hi = space_.ToUnit(upper);
  for (int i = 0; i < d; ++i) {
    const Parameter& p = space_.At(i);
    if (p.type == ParameterType::kInteger) {  // whole integer cells
      const double half = 0.5 / (p.upper - p.lower + 1.0);
      lo[i] -= half;
      hi[i] += half;
    }
  }
  unit_lower_ = lo.cwiseMax(0.0);
  unit_upper_ = hi.cwiseMin(1.0);
}

void BayesOpt::DoTell(CandidateId id, double value, double noise_variance) {
  const bool log = options_.transform == OutputTransform::kLog;
  if (log && !(value > 0.0)) {
    throw std::invalid_argument("BayesOpt: transform log needs values > 0, got " +
                                std::to_string(value));
  }
  auto it = pending_.find(id);
  Observation o;
  o.id = id;
  o.u = it->second;
  o.value = log ? std::log(value) : value;
  o.noise_variance = std::isnan(noise_variance) ? options_.default_noise_variance : noise_variance;
  pending_.erase(it);
  observations_.push_back(std::move(o));
  ++data_version_;
  ++told_since_refit_;
  ++told_since_bounds_;
}

template <class Gp>
int BayesOpt::IncumbentIndex(const Gp& gp, double* mean_std) const {
  const Eigen::VectorXd means = gp.PosteriorMeanAtData();
  Eigen::Index best = 0;
  *mean_std = means.head(static_cast<Eigen::Index>(observations_.size())).minCoeff(&best);
  return static_cast<int>(best);
}

void BayesOpt::LoadObservations(Model& model) const {
  const auto n = static_cast<Eigen::Index>(observations_.size());
  Eigen::MatrixXd x(n, space_.Dim());
  Eigen::VectorXd y(n), v(n), m(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const Observation& o = observations_[static_cast<std::size_t>(j)];
    x.row(j) = o.u.transpose();
    y[j] = o.value;
    v[j] = o.noise_variance;
    m[j] = NoiseMultiplier(o);
  }
  std::visit([&](auto& gp) { gp.SetData(x, y, v, m); }, model);
}

void BayesOpt::BuildModel(Model& model, bool refit) {
  LoadObservations(model);
  std::visit(
      [&](auto& gp) {
        if (refit) {
          const bool restart = !fitted_ || refit_count_ % options_.restart_period == 0;
          gp.Fit(rng_, restart ? options_.hyper_restarts : 0);
          fitted_ = true;
          told_since_refit_ = 0;
          ++refit_count_;
        }
        incumbent_ = IncumbentIndex(gp, &incumbent_mean_std_);
      },
      model);
}

void BayesOpt::UpdateModel() {
  if (observations_.empty() || model_version_ == data_version_) return;
  const bool refit = options_.fit_hyperparameters && (!fitted_ || told_since_refit_ >= options_.refit_every);
  BuildModel(model_, refit);
  model_version_ = data_version_;
}

void BayesOpt::UpdateBounds() {
  if (!options_.moving_bounds.enabled || told_since_bounds_ == 0 || incumbent_ < 0) {
    told_since_bounds_ = 0;
    return;
  }
  const Eigen::VectorXd& best = observations_[static_cast<std::size_t>(incumbent_)].u;
  const double lambda = options_.moving_bounds.damping;
  const double r = options_.moving_bounds.half_width;
  for (int step = 0; step < told_since_bounds_; ++step) {
    unit_upper_ = (lambda * unit_upper_ + (1.0 - lambda) * (best.array() + r).matrix()).cwiseMin(1.0).cwiseMax(0.0);
    unit_lower_ = (lambda * unit_lower_ + (1.0 - lambda) * (best.array() - r).matrix()).cwiseMax(0.0).cwiseMin(1.0);
  }
  told_since_bounds_ = 0;
}

std::optional<BestPoint> BayesOpt::Best() const {
  if (observations_.empty()) return std::nullopt;
  int index = incumbent_;
  double mean_std = incumbent_mean_std_;
  double y_mean = 0.0;
  double y_scale = 1.0;
  if (model_version_ == data_version_ && incumbent_ >= 0) {
    std::visit([&](const auto& gp) { y_mean = gp.OutputMean(); y_scale = gp.OutputScale(); }, model_);
  } else {
    Model copy = model_;
    LoadObservations(copy);
    std::visit(
        [&](auto& gp) {
          index = IncumbentIndex(gp, &mean_std);
          y_mean = gp.OutputMean();
          y_scale = gp.OutputScale();
        },
        copy);
  }
  const Observation& o = observations_[static_cast<std::size_t>(index)];
  BestPoint best;
  best.x = space_.FromUnit(o.u);
  best.value = FromModel(y_mean + y_scale * mean_std);
  best.observed = FromModel(o.value);
  best.id = o.id;
  return best;
}

std::vector<BestPoint> BayesOpt::Ranked() const {
  std::vector<BestPoint> out;
  if (observations_.empty()) return out;
  const auto n = static_cast<Eigen::Index>(observations_.size());
  Eigen::VectorXd means;
  double y_mean = 0.0;
  double y_scale = 1.0;
  Model copy = model_;  // the told observations only (no pending fantasies)
  LoadObservations(copy);
  std::visit(
      [&](const auto& gp) {
        means = gp.PosteriorMeanAtData().head(n);
        y_mean = gp.OutputMean();
        y_scale = gp.OutputScale();
      },
      copy);
  std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
  for (Eigen::Index j = 0; j < n; ++j) order[static_cast<std::size_t>(j)] = j;
  std::stable_sort(order.begin(), order.end(),
                   [&](Eigen::Index a, Eigen::Index b) { return means[a] < means[b]; });
  std::vector<Eigen::VectorXd> seen;
  for (const Eigen::Index j : order) {
    const Observation& o = observations_[static_cast<std::size_t>(j)];
    bool repeat = false;
    for (const auto& u : seen) repeat = repeat || (u - o.u).cwiseAbs().maxCoeff() < 1e-12;
    if (repeat) continue;
    seen.push_back(o.u);
    BestPoint p;
    p.x = space_.FromUnit(o.u);
    p.value = FromModel(y_mean + y_scale * means[j]);
    p.observed = FromModel(o.value);
    p.id = o.id;
    out.push_back(std::move(p));
  }
  return out;
}

void BayesOpt::Predict(const Eigen::VectorXd& x, double* mean, double* variance) {
  const Eigen::VectorXd u = space_.ToUnit(x);
  UpdateModel();
  std::visit([&](const auto& gp) { gp.Predict(u, mean, variance); }, model_);
}

GpHyperparameters BayesOpt::Hyperparameters() const {
  return std::visit([](const auto& gp) { return gp.Hyperparameters(); }, model_);
}

bool BayesOpt::IsDuplicate(const Eigen::VectorXd& u, const std::vector<Eigen::VectorXd>& batch) const {
  for (const auto& [id, p] : pending_) {
    if ((p - u).cwiseAbs().maxCoeff() < 1e-9) return true;
  }
  for (const auto& b : batch) {
    if ((b - u).cwiseAbs().maxCoeff() < 1e-9) return true;
  }
  return false;
}

double BayesOpt::FromModel(double y) const {
  return options_.transform == OutputTransform::kLog ? std::exp(y) : y;
}

CandidateId BayesOpt::Observe(const Eigen::VectorXd& x, double value,
                              std::optional<double> noise_variance) {
  if (x.size() != space_.Dim()) {
    throw std::invalid_argument("BayesOpt::Observe: point of dimension " +
                                std::to_string(x.size()) + ", space has " +
                                std::to_string(space_.Dim()));
  }
  const Candidate c = Issue(space_.ToUnit(x));
  try {
    Tell(c.id, value, noise_variance);
  } catch (...) {
    Cancel(c.id);
    throw;
  }
  return c.id;
}

Candidate BayesOpt::Issue(const Eigen::VectorXd& u) {
  Candidate c;
  c.id = next_id_++;
  c.x = space_.FromUnit(u);
  pending_.emplace(c.id, u);
  return c;
}

template <class Gp>
void BayesOpt::ProposeBatch(Gp& gp, int count, std::vector<Eigen::VectorXd>* out) {
  const int n0 = gp.Size();
  const int d = space_.Dim();
  double best_observed = observations_.front().value;
  for (const auto& o : observations_) best_observed = std::min(best_observed, o.value);
  auto fantasy = [&](const Eigen::VectorXd& u) {
    if (options_.batch_strategy == BatchStrategy::kConstantLiar) return best_observed;
    double m = 0.0;
    gp.Predict(u, &m, nullptr);
    return m;
  };
  for (const auto& [id, u] : pending_) gp.Append(u, fantasy(u), options_.default_noise_variance, 1.0);

  // Pool: uniform in the bounds plus points scattered around the incumbent and the best value.
  const int m = options_.acquisition_pool;
  const int m_local = static_cast<int>(m * options_.local_pool_fraction);
  Eigen::MatrixXd pool(d, m);
  std::size_t best_value_index = 0;
  for (std::size_t j = 0; j < observations_.size(); ++j) {
    if (observations_[j].value < observations_[best_value_index].value) best_value_index = j;
  }
  const Eigen::VectorXd width = unit_upper_ - unit_lower_;
  for (int c = 0; c < m; ++c) {
    if (c < m - m_local) {
      for (int i = 0; i < d; ++i) pool(i, c) = Uniform(rng_, unit_lower_[i], unit_upper_[i]);
    } else {
      const Eigen::VectorXd& centre =
          observations_[(c % 2 == 0) ? static_cast<std::size_t>(incumbent_) : best_value_index].u;
      const double scale = (c % 3 == 0) ? 0.01 : (c % 3 == 1 ? 0.05 : 0.2);
      for (int i = 0; i < d; ++i) {
        pool(i, c) = std::clamp(centre[i] + scale * std::max(width[i], 1e-3) * StandardNormal(rng_),
                                unit_lower_[i], unit_upper_[i]);
      }
    }
  }
  Eigen::MatrixXd v;
  Eigen::VectorXd mean, var;
  gp.PredictPool(pool, &v, &mean, &var);

  const double incumbent = incumbent_mean_std_;
  const double xi = options_.exploration;
  const ValueAndGradient neg_log_ei = [&](const Eigen::VectorXd& u, Eigen::VectorXd* grad) {
    double mu = 0.0;
    double s2 = 0.0;
    Eigen::VectorXd dmu, ds2;
    gp.PredictStandardized(u, &mu, &s2, grad ? &dmu : nullptr, grad ? &ds2 : nullptr);
    const double sigma = std::sqrt(s2);
    const double z = (incumbent - mu - xi) / sigma;
    double lh = 0.0;
    double dlh = 0.0;
    LogH(z, &lh, &dlh);
    if (grad) {
      const Eigen::VectorXd dsigma = ds2 / (2.0 * sigma);
      const Eigen::VectorXd dz = (-dmu - z * dsigma) / sigma;
      *grad = -(dsigma / sigma + dlh * dz);
    }
    return -(std::log(sigma) + lh);
  };
  BoxLbfgsOptions local;
  local.max_iterations = options_.acquisition_iterations;
  local.gradient_tolerance = 1e-5;
  local.relative_tolerance = 1e-6;

  Eigen::VectorXd score(m);
  std::vector<int> order(static_cast<std::size_t>(m));
  for (int b = 0; b < count; ++b) {
    for (int c = 0; c < m; ++c) score[c] = LogEi(incumbent, xi, mean[c], var[c]);
    std::iota(order.begin(), order.end(), 0);
    const int starts = std::max(1, std::min(options_.acquisition_starts, m));
    std::partial_sort(order.begin(), order.begin() + starts, order.end(),
                      [&](int a, int c) { return score[a] > score[c]; });
    Eigen::VectorXd best_u = pool.col(order[0]);
    double best_score = score[order[0]];
    for (int s = 0; s < options_.acquisition_starts && s < m; ++s) {
      Eigen::VectorXd u = pool.col(order[static_cast<std::size_t>(s)]);
      const BoxLbfgsSummary r = MinimizeBox(neg_log_ei, u, unit_lower_, unit_upper_, local);
      if (std::isfinite(r.value) && -r.value > best_score) {
        best_score = -r.value;
        best_u = u;
      }
    }
    Eigen::VectorXd chosen = space_.SnapUnit(best_u);
    if (IsDuplicate(chosen, *out)) {
      std::sort(order.begin(), order.end(), [&](int a, int c) { return score[a] > score[c]; });
      bool found = false;
      for (int idx : order) {
        const Eigen::VectorXd u = space_.SnapUnit(pool.col(idx));
        if (!IsDuplicate(u, *out)) {
          chosen = u;
          found = true;
          break;
        }
      }
      for (int attempt = 0; !found && attempt < 100; ++attempt) {
        Eigen::VectorXd u(d);
        for (int i = 0; i < d; ++i) u[i] = Uniform(rng_, unit_lower_[i], unit_upper_[i]);
        u = space_.SnapUnit(u);
        found = !IsDuplicate(u, *out);
        if (found) chosen = u;
      }
      if (!found) break;  // the (integer) bounds hold no further distinct point
    }
    out->push_back(chosen);
    if (b + 1 < count) {
      gp.Append(chosen, fantasy(chosen), options_.default_noise_variance, 1.0);
      gp.ExtendPool(pool, &v, &mean, &var);
    }
  }
  gp.Truncate(n0);
}

std::vector<Candidate> BayesOpt::DoAsk(int k) {
  UpdateModel();
  UpdateBounds();
  const int d = space_.Dim();
  if (!design_generated_) {
    design_generated_ = true;
    if (options_.initial_design_size > 0) {
      const Eigen::MatrixXd design =
          options_.initial_design == InitialDesign::kLatinHypercube
              ? LatinHypercube(options_.initial_design_size, Eigen::VectorXd::Zero(d), Eigen::VectorXd::Ones(d), rng_)
              : UniformDesign(options_.initial_design_size, Eigen::VectorXd::Zero(d), Eigen::VectorXd::Ones(d), rng_);
      for (Eigen::Index r = 0; r < design.rows(); ++r) design_queue_.push_back(design.row(r).transpose());
    }
  }
  std::vector<Candidate> out;
  std::vector<Eigen::VectorXd> none;
  while (static_cast<int>(out.size()) < k && !design_queue_.empty()) {
    // Design points are fractions of the current bounds, so moving bounds also move them.
    const Eigen::VectorXd t = design_queue_.front();
    const Eigen::VectorXd u =
        space_.SnapUnit(unit_lower_ + t.cwiseProduct(unit_upper_ - unit_lower_));
    design_queue_.pop_front();
    if (!IsDuplicate(u, none)) out.push_back(Issue(u));
  }
  const int remaining = k - static_cast<int>(out.size());
  if (remaining <= 0) return out;
  std::vector<Eigen::VectorXd> batch;
  if (observations_.size() < 2) {
    for (int r = 0; r < remaining; ++r) {
      for (int attempt = 0; attempt < 100; ++attempt) {
        Eigen::VectorXd u(d);
        for (int i = 0; i < d; ++i) u[i] = Uniform(rng_, unit_lower_[i], unit_upper_[i]);
        u = space_.SnapUnit(u);
        if (!IsDuplicate(u, batch)) {
          batch.push_back(u);
          break;
        }
      }
    }
  } else {
    std::visit([&](auto& gp) { ProposeBatch(gp, remaining, &batch); }, model_);
  }
  for (const auto& u : batch) out.push_back(Issue(u));
  return out;
}

nlohmann::json BayesOpt::SaveState() const {
  using detail::ToJson;
  nlohmann::json j;
  j["method"] = "bayes_opt";
  j["dim"] = space_.Dim();
  j["kernel"] = ToString(options_.kernel);
  j["rng"] = detail::RngToString(rng_);
  j["next_id"] = next_id_;
  j["design_generated"] = design_generated_;
  j["design_queue"] = nlohmann::json::array();
  for (const auto& u : design_queue_) j["design_queue"].push_back(ToJson(u));
  j["observations"] = nlohmann::json::array();
  for (const auto& o : observations_) {
    j["observations"].push_back({{"id", o.id}, {"u", ToJson(o.u)}, {"value", o.value},
                                 {"noise_variance", o.noise_variance}, {"discount_count", o.discount_count},
                                 {"age", o.age}});
  }
  j["pending"] = nlohmann::json::array();
  for (const auto& [id, u] : pending_) j["pending"].push_back({{"id", id}, {"u", ToJson(u)}});
  j["unit_lower"] = ToJson(unit_lower_);
  j["unit_upper"] = ToJson(unit_upper_);
  const GpHyperparameters h = Hyperparameters();
  j["hyper"] = {{"log_lengthscales", ToJson(h.log_lengthscales)},
                {"log_signal_std", h.log_signal_std},
                {"log_noise_std", h.log_noise_std}};
  j["fitted"] = fitted_;
  j["told_since_refit"] = told_since_refit_;
  j["refit_count"] = refit_count_;
  j["told_since_bounds"] = told_since_bounds_;
  return j;
}

void BayesOpt::RestoreState(const nlohmann::json& state) {
  detail::CheckHeader(state, "bayes_opt", space_.Dim());
  const int d = space_.Dim();
  detail::WithJsonErrors([&] {
    if (state.at("kernel").get<std::string>() != ToString(options_.kernel)) {
      throw std::invalid_argument("BayesOpt::RestoreState: saved with kernel '" +
                                  state.at("kernel").get<std::string>() + "'");
    }
    Rng rng = detail::RngFromString(state.at("rng").get<std::string>());
    std::deque<Eigen::VectorXd> queue;
    for (const auto& u : state.at("design_queue")) queue.push_back(detail::VectorFromJson(u, d));
    std::vector<Observation> obs;
    for (const auto& o : state.at("observations")) {
      Observation x;
      x.id = o.at("id").get<CandidateId>();
      x.u = detail::VectorFromJson(o.at("u"), d);
      x.value = o.at("value").get<double>();
      x.noise_variance = o.at("noise_variance").get<double>();
      x.discount_count = o.at("discount_count").get<int>();
      x.age = o.at("age").get<double>();
      obs.push_back(std::move(x));
    }
    std::map<CandidateId, Eigen::VectorXd> pending;
    for (const auto& p : state.at("pending")) {
      pending.emplace(p.at("id").get<CandidateId>(), detail::VectorFromJson(p.at("u"), d));
    }
    GpHyperparameters h;
    h.log_lengthscales = detail::VectorFromJson(state.at("hyper").at("log_lengthscales"), d);
    h.log_signal_std = state.at("hyper").at("log_signal_std").get<double>();
    h.log_noise_std = state.at("hyper").at("log_noise_std").get<double>();
    Model model = MakeModel(options_.kernel, d, options_.gp);
    std::visit([&](auto& gp) { gp.SetHyperparameters(h); }, model);
    const auto next_id = state.at("next_id").get<CandidateId>();
    const bool design_generated = state.at("design_generated").get<bool>();
    Eigen::VectorXd lower = detail::VectorFromJson(state.at("unit_lower"), d);
    Eigen::VectorXd upper = detail::VectorFromJson(state.at("unit_upper"), d);
    const bool fitted = state.at("fitted").get<bool>();
    const int told_since_refit = state.at("told_since_refit").get<int>();
    const int refit_count = state.at("refit_count").get<int>();
    const int told_since_bounds = state.at("told_since_bounds").get<int>();
    // Commit only after everything parsed.
    rng_ = rng;
    next_id_ = next_id;
    design_generated_ = design_generated;
    design_queue_ = std::move(queue);
    observations_ = std::move(obs);
    pending_ = std::move(pending);
    unit_lower_ = std::move(lower);
    unit_upper_ = std::move(upper);
    model_ = std::move(model);
    fitted_ = fitted;
    told_since_refit_ = told_since_refit;
    refit_count_ = refit_count;
    told_since_bounds_ = told_since_bounds;
    incumbent_ = -1;
    ++data_version_;
  });
}

}  // namespace quadtune::optimizers
