#include "quadtune/optimizers/parameter_space.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

namespace quadtune::optimizers {
namespace {

std::string Join(const std::string& prefix, const std::string& key) {
  return prefix.empty() ? key : prefix + "." + key;
}

bool IsIntegral(double v) { return std::isfinite(v) && std::floor(v) == v; }

/// The value of `p` at unit coordinate t in [0, 1] on its continuous scale: an integer
/// parameter as the stretch of the real line its cells cover, [lower - 0.5, upper + 0.5].
double ContinuousValue(const Parameter& p, double t) {
  if (p.type == ParameterType::kInteger) return p.lower - 0.5 + t * (p.upper - p.lower + 1.0);
  if (p.log_scale) {
    return std::clamp(std::exp(std::log(p.lower) + t * (std::log(p.upper) - std::log(p.lower))),
                      p.lower, p.upper);
  }
  return p.lower + t * (p.upper - p.lower);
}

}  // namespace

const Fields<Parameter>& ParameterFields() {
  static const Fields<Parameter> fields =
      Fields<Parameter>()
          .Text("name", &Parameter::name, {}, "a tunable parameter of the planner; unique")
          .Required()
          .Number("lower", &Parameter::lower, Range::Any(), "lower search bound, < `upper`")
          .Required()
          .Number("upper", &Parameter::upper, Range::Any(), "upper search bound")
          .Required()
          .Choice("type", &Parameter::type, "integer parameters are rounded in issued candidates")
          .Flag("log", &Parameter::log_scale, "search on a log scale (continuous, lower > 0)")
          .OptionalNumber("default", &Parameter::default_value, Range::Any(),
                          "value flown by method `default` and by untuned parameters, inside "
                          "the bounds; absent: the planner's default");
  return fields;
}

void Parameter::Validate(const std::string& file, const std::string& key_prefix) const {
  if (name.empty()) throw ConfigError(file, Join(key_prefix, "name"), "must not be empty");
  ParameterFields().Check(*this, file, key_prefix.empty() ? "" : key_prefix + ".");
  if (!(lower < upper)) {
    throw ConfigError(file, Join(key_prefix, "upper"),
                      "parameter '" + name + "': upper bound " + std::to_string(upper) +
                          " must be greater than lower bound " + std::to_string(lower));
  }
  if (log_scale && lower <= 0.0) {
    throw ConfigError(file, Join(key_prefix, "lower"),
                      "parameter '" + name + "': a log-scale parameter needs lower > 0, got " +
                          std::to_string(lower));
  }
  if (type == ParameterType::kInteger) {
    if (log_scale) {
      throw ConfigError(file, Join(key_prefix, "log"),
                        "parameter '" + name + "': log scale is only allowed for continuous parameters");
    }
    if (!IsIntegral(lower) || !IsIntegral(upper)) {
      throw ConfigError(file, Join(key_prefix, "lower"),
                        "parameter '" + name + "': integer parameter bounds must be integers");
    }
  }
  if (default_value) {
    const double v = *default_value;
    if (v < lower || v > upper) {
      throw ConfigError(file, Join(key_prefix, "default"),
                        "parameter '" + name + "': default must lie in [" + std::to_string(lower) +
                            ", " + std::to_string(upper) + "]");
    }
    if (type == ParameterType::kInteger && !IsIntegral(v)) {
      throw ConfigError(file, Join(key_prefix, "default"),
                        "parameter '" + name + "': default of an integer parameter must be an integer");
    }
  }
}

ParameterSpace::ParameterSpace(std::vector<Parameter> parameters) : parameters_(std::move(parameters)) {
  if (parameters_.empty()) throw ConfigError("", "parameters", "the parameter space must not be empty");
  std::set<std::string> names;
  for (std::size_t i = 0; i < parameters_.size(); ++i) {
    const std::string key = "parameters[" + std::to_string(i) + "]";
    parameters_[i].Validate("", key);
    if (!names.insert(parameters_[i].name).second) {
      throw ConfigError("", key + ".name", "duplicate parameter name '" + parameters_[i].name + "'");
    }
  }
}

ParameterSpace ParameterSpace::FromYaml(const YamlMap& map) {
  const std::vector<YamlMap> items = map.Maps("parameters");
  if (items.empty()) map.Fail("parameters", "expected a non-empty sequence of parameters");
  std::vector<Parameter> params;
  std::set<std::string> names;
  for (const YamlMap& item : items) {
    Parameter p = ParameterFields().Read(item);
    p.Validate(item.file(), item.path());
    if (!names.insert(p.name).second) item.Fail("name", "duplicate parameter name '" + p.name + "'");
    params.push_back(std::move(p));
  }
  return ParameterSpace(std::move(params));
}

std::vector<std::string> ParameterSpace::Names() const {
  std::vector<std::string> out;
  out.reserve(parameters_.size());
  for (const auto& p : parameters_) out.push_back(p.name);
  return out;
}

int ParameterSpace::IndexOf(const std::string& name) const {
  for (std::size_t i = 0; i < parameters_.size(); ++i) {
    if (parameters_[i].name == name) return static_cast<int>(i);
  }
  std::string known;
  for (const auto& p : parameters_) known += (known.empty() ? "" : ", ") + p.name;
  throw ConfigError("", name, "unknown parameter '" + name + "'; known parameters: " + known);
}

Eigen::VectorXd ParameterSpace::Lower() const {
  Eigen::VectorXd v(Dim());
  for (int i = 0; i < Dim(); ++i) v[i] = parameters_[static_cast<std::size_t>(i)].lower;
  return v;
}

Eigen::VectorXd ParameterSpace::Upper() const {
  Eigen::VectorXd v(Dim());
  for (int i = 0; i < Dim(); ++i) v[i] = parameters_[static_cast<std::size_t>(i)].upper;
  return v;
}

Eigen::VectorXd ParameterSpace::Defaults() const {
  Eigen::VectorXd x = FromUnit(Eigen::VectorXd::Constant(Dim(), 0.5));
  for (int i = 0; i < Dim(); ++i) {
    const auto& p = parameters_[static_cast<std::size_t>(i)];
    if (p.default_value) x[i] = *p.default_value;
  }
  return x;
}

void ParameterSpace::CheckSize(const Eigen::VectorXd& v, const char* what) const {
  if (v.size() != Dim()) {
    throw std::invalid_argument(std::string(what) + ": expected a vector of size " +
                                std::to_string(Dim()) + ", got " + std::to_string(v.size()));
  }
  if (v.hasNaN()) throw std::invalid_argument(std::string(what) + ": vector holds NaN");
}

Eigen::VectorXd ParameterSpace::ToUnit(const Eigen::VectorXd& x) const {
  CheckSize(x, "ParameterSpace::ToUnit");
  Eigen::VectorXd u(Dim());
  for (int i = 0; i < Dim(); ++i) {
    const auto& p = parameters_[static_cast<std::size_t>(i)];
    const double v = std::clamp(x[i], p.lower, p.upper);
    if (p.type == ParameterType::kInteger) {
      u[i] = (std::round(v) - p.lower + 0.5) / (p.upper - p.lower + 1.0);
    } else if (p.log_scale) {
      u[i] = (std::log(v) - std::log(p.lower)) / (std::log(p.upper) - std::log(p.lower));
    } else {
      u[i] = (v - p.lower) / (p.upper - p.lower);
    }
    u[i] = std::clamp(u[i], 0.0, 1.0);
  }
  return u;
}

Eigen::VectorXd ParameterSpace::FromUnit(const Eigen::VectorXd& u) const {
  CheckSize(u, "ParameterSpace::FromUnit");
  Eigen::VectorXd x(Dim());
  for (int i = 0; i < Dim(); ++i) {
    const auto& p = parameters_[static_cast<std::size_t>(i)];
    const double t = std::clamp(u[i], 0.0, 1.0);
    const double v = p.type == ParameterType::kInteger
                         ? p.lower + std::floor(t * (p.upper - p.lower + 1.0))
                         : ContinuousValue(p, t);
    x[i] = std::clamp(v, p.lower, p.upper);
  }
  return x;
}

Eigen::VectorXd ParameterSpace::FromUnitContinuous(const Eigen::VectorXd& u) const {
  CheckSize(u, "ParameterSpace::FromUnitContinuous");
  Eigen::VectorXd x(Dim());
  for (int i = 0; i < Dim(); ++i) {
    x[i] = ContinuousValue(parameters_[static_cast<std::size_t>(i)], std::clamp(u[i], 0.0, 1.0));
  }
  return x;
}

Eigen::VectorXd ParameterSpace::SnapUnit(const Eigen::VectorXd& u) const {
  CheckSize(u, "ParameterSpace::SnapUnit");
  Eigen::VectorXd s = u.cwiseMax(0.0).cwiseMin(1.0);
  for (int i = 0; i < Dim(); ++i) {
    const auto& p = parameters_[static_cast<std::size_t>(i)];
    if (p.type != ParameterType::kInteger) continue;
    const double cells = p.upper - p.lower + 1.0;
    const double k = std::min(std::floor(s[i] * cells), cells - 1.0);
    s[i] = (k + 0.5) / cells;
  }
  return s;
}

bool ParameterSpace::Contains(const Eigen::VectorXd& x) const {
  if (x.size() != Dim()) return false;
  for (int i = 0; i < Dim(); ++i) {
    const auto& p = parameters_[static_cast<std::size_t>(i)];
    if (!(x[i] >= p.lower && x[i] <= p.upper)) return false;
    if (p.type == ParameterType::kInteger && !IsIntegral(x[i])) return false;
  }
  return true;
}

Eigen::VectorXd ParameterSpace::FromNamed(const std::map<std::string, double>& values) const {
  Eigen::VectorXd x(Dim());
  std::vector<bool> seen(parameters_.size(), false);
  for (const auto& [name, value] : values) {
    const int i = IndexOf(name);
    x[i] = value;
    seen[static_cast<std::size_t>(i)] = true;
  }
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (!seen[i]) {
      throw ConfigError("", parameters_[i].name,
                        "missing value for parameter '" + parameters_[i].name + "'");
    }
  }
  return x;
}

std::map<std::string, double> ParameterSpace::ToNamed(const Eigen::VectorXd& x) const {
  if (x.size() != Dim()) {
    throw std::invalid_argument("ParameterSpace::ToNamed: expected a vector of size " +
                                std::to_string(Dim()) + ", got " + std::to_string(x.size()));
  }
  std::map<std::string, double> out;
  for (int i = 0; i < Dim(); ++i) out[parameters_[static_cast<std::size_t>(i)].name] = x[i];
  return out;
}

ParameterSpace ParameterSpace::Subspace(const std::vector<std::string>& names) const {
  std::vector<Parameter> params;
  params.reserve(names.size());
  for (const auto& n : names) params.push_back(parameters_[static_cast<std::size_t>(IndexOf(n))]);
  if (params.empty()) throw std::invalid_argument("ParameterSpace::Subspace: no names given");
  return ParameterSpace(std::move(params));
}

}  // namespace quadtune::optimizers
