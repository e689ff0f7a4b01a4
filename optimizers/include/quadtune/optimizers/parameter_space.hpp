#pragma once
/// \file
/// Named, bounded parameter spaces and their map to the unit cube, the coordinates in which every
/// quadtune optimizer works.
///
/// Thread safety: a ParameterSpace is an immutable value after construction; concurrent const use
/// is safe.

#include <Eigen/Core>
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::optimizers {

/// Whether a parameter takes any real value in its bounds or only integers.
enum class ParameterType { kContinuous, kInteger };
constexpr auto EnumNames(ParameterType) {
  return std::array{EnumName{ParameterType::kContinuous, "continuous"},
                    EnumName{ParameterType::kInteger, "integer"}};
}

/// One tunable parameter, e.g. the paper's collision weight w_col (continuous, log scale) or the
/// number of polynomial pieces n_pol (integer).
struct Parameter {
  std::string name;                    ///< unique, non-empty
  double lower = 0.0;                  ///< lower bound (inclusive), in the parameter's own unit
  double upper = 1.0;                  ///< upper bound (inclusive), > lower
  ParameterType type = ParameterType::kContinuous;  ///< integer parameters are rounded
  bool log_scale = false;              ///< search uniformly in log(value); needs lower > 0
  std::optional<double> default_value; ///< the planner's default, inside [lower, upper]

  /// Throws ConfigError naming `key_prefix`.<field> when a field is out of range: empty name,
  /// non-finite or crossed bounds, log scale with lower <= 0, log scale on an integer parameter,
  /// integer bounds that are not integers, or a default outside the bounds.
  void Validate(const std::string& file = "", const std::string& key_prefix = "") const;
};

/// The keys of one item of `parameters:` (the list itself is read by ParameterSpace::FromYaml).
const Fields<Parameter>& ParameterFields();

/// An ordered list of named parameters, and the conversions between their values ("original
/// coordinates") and the unit cube [0, 1]^d ("unit coordinates").
///
/// Unit coordinates: continuous linear parameters map affinely, u = (x - lower) / (upper - lower);
/// log-scale parameters map u = (ln x - ln lower) / (ln upper - ln lower); an integer parameter
/// with bounds [a, b] maps the cell [k - 0.5, k + 0.5] of each integer k to an equal share of
/// [0, 1], u = (x - a + 0.5) / (b - a + 1), so uniform sampling in u picks every integer equally
/// often.
class ParameterSpace {
 public:
  /// An empty space (dimension 0); optimizers reject it.
  ParameterSpace() = default;
  /// Validates every parameter and the uniqueness of names; throws ConfigError otherwise
  /// (also when `parameters` is empty).
  explicit ParameterSpace(std::vector<Parameter> parameters);

  /// Reads `parameters:`, a sequence of maps with the keys of ParameterFields(): name, lower,
  /// upper, type ("continuous" | "integer", default continuous), log (bool, default false) and
  /// default (optional number), e.g.
  ///
  ///     parameters:
  ///       - {name: w_col, lower: 0.05, upper: 5.0, log: true, default: 0.5}
  ///       - {name: n_pol, lower: 3, upper: 12, type: integer, default: 5}
  ///
  /// Unknown keys, missing bounds, crossed bounds and duplicate names throw ConfigError naming
  /// the file and key.
  static ParameterSpace FromYaml(const YamlMap& map);

  /// Number of parameters d.
  [[nodiscard]] int Dim() const { return static_cast<int>(parameters_.size()); }
  /// True when the space has no parameter.
  [[nodiscard]] bool Empty() const { return parameters_.empty(); }
  /// The i-th parameter (0 <= i < Dim(); throws std::out_of_range otherwise).
  [[nodiscard]] const Parameter& At(int i) const { return parameters_.at(static_cast<std::size_t>(i)); }
  /// All parameters in order.
  [[nodiscard]] const std::vector<Parameter>& Parameters() const { return parameters_; }
  /// Parameter names in order.
  [[nodiscard]] std::vector<std::string> Names() const;
  /// Index of `name`; throws ConfigError (key `name`) listing the known names when unknown.
  [[nodiscard]] int IndexOf(const std::string& name) const;

  /// Lower / upper bounds in original coordinates.
  [[nodiscard]] Eigen::VectorXd Lower() const;
  [[nodiscard]] Eigen::VectorXd Upper() const;
  /// Defaults in original coordinates; parameters without a default take the centre of their
  /// unit interval.
  [[nodiscard]] Eigen::VectorXd Defaults() const;

  /// Original → unit coordinates. Values outside the bounds are clamped first.
  /// Throws std::invalid_argument when x.size() != Dim() or x holds NaN.
  [[nodiscard]] Eigen::VectorXd ToUnit(const Eigen::VectorXd& x) const;
  /// Unit → original coordinates: clamps u to [0, 1] and rounds integer parameters.
  /// Throws std::invalid_argument when u.size() != Dim() or u holds NaN.
  [[nodiscard]] Eigen::VectorXd FromUnit(const Eigen::VectorXd& u) const;
  /// Unit → original coordinates without rounding (integer parameter k's cell is [k − 0.5,
  /// k + 0.5]); used to report search bounds. Throws like FromUnit.
  [[nodiscard]] Eigen::VectorXd FromUnitContinuous(const Eigen::VectorXd& u) const;
  /// Snaps unit coordinates to the representable points: clamp to [0, 1] and move integer
  /// coordinates to the centre of their integer cell (ToUnit(FromUnit(u))).
  [[nodiscard]] Eigen::VectorXd SnapUnit(const Eigen::VectorXd& u) const;
  /// True when x has Dim() entries, each inside its bounds, integers integral.
  [[nodiscard]] bool Contains(const Eigen::VectorXd& x) const;

  /// Named values → vector. Every parameter must be present; an unknown or missing name throws
  /// ConfigError naming it.
  [[nodiscard]] Eigen::VectorXd FromNamed(const std::map<std::string, double>& values) const;
  /// Vector → named values (throws std::invalid_argument on a wrong size).
  [[nodiscard]] std::map<std::string, double> ToNamed(const Eigen::VectorXd& x) const;

  /// The sub-space of the named parameters, in the given order (e.g. θ_s or θ_l out of θ).
  /// Unknown names throw ConfigError (IndexOf); an empty list std::invalid_argument.
  [[nodiscard]] ParameterSpace Subspace(const std::vector<std::string>& names) const;

 private:
  void CheckSize(const Eigen::VectorXd& v, const char* what) const;

  std::vector<Parameter> parameters_;
};

}  // namespace quadtune::optimizers
