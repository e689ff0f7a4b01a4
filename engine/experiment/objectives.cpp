#include "quadtune/engine/experiment/objectives.hpp"

#include <algorithm>

#include "field_util.hpp"

namespace quadtune::engine {

const Fields<ObjectiveOptions>& ObjectiveShortTermFields() {
  using O = ObjectiveOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Choice("kind", &O::short_kind, "which f_s")
          .Number("w_t", &O::w_t, Range::NonNegative(), "weight of J_t (or t_exe)")
          .Number("w_s", &O::w_s, Range::NonNegative(), "weight of n_s (failed attempts)")
          .Number("w_tau", &O::w_tau, Range::NonNegative(), "real-time penalty weight (1/s²)")
          .Number("tau_t", &O::tau_t, Range::Positive(), "real-time threshold τ_t (s)")
          .Number("w_p", &O::w_p, Range::NonNegative(), "jerk weight (changing environment)")
          .Number("w_c", &O::w_c, Range::NonNegative(),
                  "clearance weight; absent: 0 for `solve_time`, 100 for "
                  "`changing_environment`")
          .Number("clearance", &O::clearance, Range::Positive(), "desired clearance C (m)")
          .Number("unit_time", &O::unit_time, Range::Positive(),
                  "seconds per compute unit (reproducible mode) (s)");
  return fields;
}

const Fields<ObjectiveOptions>& ObjectiveLongTermFields() {
  static const Fields<ObjectiveOptions> fields = Fields<ObjectiveOptions>().Number(
      "w_e", &ObjectiveOptions::w_e, Range::NonNegative(), "cost per emergency stop (s)");
  return fields;
}

const Fields<ObjectiveOptions>& ObjectiveFields() {
  using O = ObjectiveOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Custom(
              MapDoc("short_term", "weights of f_s, below"),
              [](const YamlMap& map, O& o) {
                const YamlMap s = map.Map("short_term", /*optional=*/true);
                ObjectiveShortTermFields().Read(s, o);
                if (!s.Has("w_c")) {
                  o.w_c =
                      o.short_kind == O::ShortKind::kSolveTime ? 0.0 : O::kDefaultClearanceWeight;
                }
              },
              WriteSection("short_term", ObjectiveShortTermFields()))
          .Custom(MapDoc("long_term", "weights of f_l, below"),
                  ReadSection("long_term", ObjectiveLongTermFields()),
                  WriteSection("long_term", ObjectiveLongTermFields()))
          .Number("failure_value", &O::failure_value, Range::Positive(),
                  "value told to an optimiser for a failed evaluation");
  return fields;
}

void ObjectiveOptions::Validate(const std::string& file) const {
  ObjectiveShortTermFields().Check(*this, file, "objective.short_term.");
  ObjectiveLongTermFields().Check(*this, file, "objective.long_term.");
  ObjectiveFields().Check(*this, file, "objective.");
}

ObjectiveOptions ObjectiveOptions::FromYaml(const YamlMap& map) {
  return ObjectiveFields().Read(map);
}

ObjectiveValue LongTermObjective(const FlightRecord& f, const ObjectiveOptions& o) {
  ObjectiveValue v;
  const double n_c = f.collisions;
  const double n_e = f.emergency_stops;
  v.terms = {{"t_f", f.flight_time}, {"n_c", n_c}, {"n_e", n_e}, {"queries", static_cast<double>(f.queries)},
             {"completed", f.completed ? 1.0 : 0.0}, {"plans", static_cast<double>(f.plans)},
             {"failed_attempts", static_cast<double>(f.failed_attempts)},
             {"fallback_plans", static_cast<double>(f.fallback_plans)},
             {"compute_units", f.compute_units}, {"jerk_integral", f.jerk_integral},
             {"min_clearance", f.min_clearance}};
  if (f.status != EvalStatus::kOk) {
    v.value = o.failure_value;
    return v;
  }
  v.value = f.flight_time + f.flight_time * n_c + o.w_e * n_e;
  // A flight that did not finish its mission is at least as bad as the failure value.
  if (!f.completed) v.value = std::max(v.value, o.failure_value);
  return v;
}

ObjectiveValue ShortTermObjective(const ResolveRecord& s, const ObjectiveOptions& o,
                                  TimingMode mode) {
  ObjectiveValue v;
  const double t_c = mode == TimingMode::kRealtime ? s.solve_time_s : s.compute_units * o.unit_time;
  v.terms = {{"t_c", t_c}, {"n_s", static_cast<double>(s.failed_attempts)},
             {"compute_units", s.compute_units}, {"success", s.success ? 1.0 : 0.0},
             {"t_exe", s.duration}, {"jerk_integral", s.jerk_integral},
             {"min_clearance", s.min_clearance}};
  if (s.status != EvalStatus::kOk) {
    v.value = o.failure_value;
    return v;
  }
  const double gap = o.clearance - s.min_clearance;
  const double j_c = s.min_clearance < o.clearance ? gap * gap : 0.0;
  v.terms["J_c"] = j_c;
  if (o.short_kind == ObjectiveOptions::ShortKind::kSolveTime) {
    const double over = std::max(0.0, t_c - o.tau_t);
    const double j_t = t_c + o.w_tau * over * over;
    const double j_s = s.failed_attempts;
    v.terms["J_t"] = j_t;
    v.terms["J_s"] = j_s;
    v.value = o.w_t * j_t + o.w_s * j_s + o.w_c * j_c;
  } else {
    v.value = s.success ? o.w_t * s.duration + o.w_p * s.jerk_integral + o.w_c * j_c
                        : o.failure_value;
  }
  return v;
}

EvalState StateOf(const FlightRecord& f) {
  if (f.status == EvalStatus::kCancelled) return EvalState::kCancelled;
  if (f.status == EvalStatus::kFailed) {
    return f.ending == EvalState::kDiverged ? EvalState::kDiverged : EvalState::kError;
  }
  if (!f.completed) {
    if (f.plans > 0 && f.fallback_plans == f.plans) return EvalState::kSolverFailure;
    return f.ending == EvalState::kOk ? EvalState::kIncomplete : f.ending;
  }
  return f.collisions > 0 ? EvalState::kCollision : EvalState::kOk;
}

EvalState StateOf(const ResolveRecord& s) {
  if (s.status == EvalStatus::kCancelled) return EvalState::kCancelled;
  if (s.status == EvalStatus::kFailed) return EvalState::kError;
  return s.success ? EvalState::kOk : EvalState::kSolverFailure;
}

}  // namespace quadtune::engine
