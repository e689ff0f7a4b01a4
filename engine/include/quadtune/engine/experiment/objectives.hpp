#pragma once
/// \file
/// The objectives, as weighted terms whose weights come from the experiment file.
///
/// - Short-term, solve-time kind (paper Sec. III-D): f_s = w_t J_t + w_s J_s with
///   J_t = t_c + w_τ max(0, t_c − τ_t)² and J_s = n_s; optionally + w_c J_c (the clearance
///   penalty below), off unless short_term.w_c is given.
/// - Short-term, changing-environment kind (paper Sec. IV-B): f_s = w_t t_exe + w_p ∫jerk² +
///   w_c J_c with J_c = (C − c_obs)² when c_obs < C, else 0.
/// - Long-term (paper Sec. IV-A): f_l = t_f + t_f·n_c + w_e·n_e.
///
/// t_c: in realtime mode the measured wall-clock solve time; in reproducible mode it is derived
/// from the planner's deterministic compute units, t_c = compute_units · unit_time (default
/// 1 unit = 1e-4 s = 0.1 ms), so a run gives identical results at any thread count.
///
/// Thread safety: value types; the functions are pure.

#include <map>
#include <string>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/api/planner.hpp"

namespace quadtune::engine {

/// How solve times are measured.
enum class TimingMode { kReproducible, kRealtime };
constexpr auto EnumNames(TimingMode) {
  return std::array{EnumName{TimingMode::kReproducible, "reproducible"},
                    EnumName{TimingMode::kRealtime, "realtime"}};
}

/// Weights of the objectives (YAML `objective:`).
struct ObjectiveOptions {
  /// Default w_c of the changing-environment f_s.
  static constexpr double kDefaultClearanceWeight = 100.0;
  enum class ShortKind { kSolveTime, kChangingEnvironment };
  ShortKind short_kind = ShortKind::kSolveTime;  ///< short_term.kind: solve_time | changing_environment
  double w_t = 1.0;        ///< short_term.w_t >= 0 (1/s for solve_time)
  double w_s = 0.01;       ///< short_term.w_s >= 0, weight of n_s
  double w_tau = 1000.0;   ///< short_term.w_tau >= 0 (1/s²), real-time penalty weight (≫ 1)
  double tau_t = 0.05;     ///< short_term.tau_t > 0, real-time threshold τ_t (s)
  double w_p = 0.01;       ///< short_term.w_p >= 0, jerk weight (changing environment)
  /// short_term.w_c >= 0, clearance weight. Its default depends on the kind: 0 for solve_time
  /// (the paper's f_s, the J_c term off), kDefaultClearanceWeight for changing_environment.
  double w_c = 0.0;
  double clearance = 0.5;  ///< short_term.clearance > 0, desired clearance C (m)
  double unit_time = 1e-4; ///< short_term.unit_time > 0: seconds per compute unit (reproducible)
  double w_e = 5.0;        ///< long_term.w_e >= 0 (s per emergency stop)
  /// Value of a failed evaluation (long and short), > 0: what an optimiser is told instead.
  double failure_value = 1000.0;

  /// Throws ConfigError(file, key, ...) naming the first bad key.
  void Validate(const std::string& file = "") const;
  /// Reads `objective:` (ObjectiveFields) over the defaults; unknown keys throw.
  static ObjectiveOptions FromYaml(const YamlMap& map);
};
constexpr auto EnumNames(ObjectiveOptions::ShortKind) {
  using Kind = ObjectiveOptions::ShortKind;
  return std::array{EnumName{Kind::kSolveTime, "solve_time"},
                    EnumName{Kind::kChangingEnvironment, "changing_environment"}};
}

/// `objective:`: maps short_term (ObjectiveShortTermFields) and long_term
/// (ObjectiveLongTermFields), key failure_value. Reading into inherited values keeps them for
/// absent keys, except short_term.w_c, whose absence gives the default of short_term.kind.
const Fields<ObjectiveOptions>& ObjectiveFields();
/// `objective.short_term:`.
const Fields<ObjectiveOptions>& ObjectiveShortTermFields();
/// `objective.long_term:`.
const Fields<ObjectiveOptions>& ObjectiveLongTermFields();

/// An objective value with its named terms (stored in the results).
struct ObjectiveValue {
  double value = 0.0;
  std::map<std::string, double> terms;
};

/// f_l of a flight.
ObjectiveValue LongTermObjective(const FlightRecord& flight, const ObjectiveOptions& o);
/// f_s of one re-solve, t_c taken per `mode`.
ObjectiveValue ShortTermObjective(const ResolveRecord& solve, const ObjectiveOptions& o,
                                  TimingMode mode);

/// The stored state of a flight: cancelled and failed flights by their status (a failure by
/// its `ending`: diverged, else error), an unfinished flight by its `ending` (solver_failure
/// when it had plans and every one fell back to stop-and-go; incomplete when the planner gave
/// no ending), a finished one collision when it collided, else ok.
EvalState StateOf(const FlightRecord& flight);
/// The stored state of a re-solve: cancelled, error, solver_failure (no trajectory) or ok.
EvalState StateOf(const ResolveRecord& solve);

}  // namespace quadtune::engine
