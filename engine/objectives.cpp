#include "quadtune/engine/objectives.hpp"

#include <algorithm>

namespace quadtune::engine {

void ObjectiveOptions::Validate(const std::string& file) const {
  CheckInRange(w_t, Range::NonNegative(), file, "objective.short_term.w_t");
  CheckInRange(w_s, Range::NonNegative(), file, "objective.short_term.w_s");
  CheckInRange(w_tau, Range::NonNegative(), file, "objective.short_term.w_tau");
  CheckInRange(tau_t, Range::Positive(), file, "objective.short_term.tau_t");
  CheckInRange(w_p, Range::NonNegative(), file, "objective.short_term.w_p");
  CheckInRange(w_c, Range::NonNegative(), file, "objective.short_term.w_c");
  CheckInRange(clearance, Range::Positive(), file, "objective.short_term.clearance");
  CheckInRange(unit_time, Range::Positive(), file, "objective.short_term.unit_time");
  CheckInRange(w_e, Range::NonNegative(), file, "objective.long_term.w_e");
  CheckInRange(failure_value, Range::Positive(), file, "objective.failure_value");
}

ObjectiveOptions ObjectiveOptions::FromYaml(const YamlMap& map) {
  ObjectiveOptions o;
  map.RejectUnknownKeys({"short_term", "long_term", "failure_value"});
  const YamlMap s = map.Map("short_term", true);
  s.RejectUnknownKeys({"kind", "w_t", "w_s", "w_tau", "tau_t", "w_p", "w_c", "clearance", "unit_time"});
  o.short_kind = s.String("kind", "solve_time", {"solve_time", "changing_environment"}) == "solve_time"
                     ? ShortKind::kSolveTime
                     : ShortKind::kChangingEnvironment;
  o.w_t = s.Number("w_t", o.w_t, Range::NonNegative());
  o.w_s = s.Number("w_s", o.w_s, Range::NonNegative());
  o.w_tau = s.Number("w_tau", o.w_tau, Range::NonNegative());
  o.tau_t = s.Number("tau_t", o.tau_t, Range::Positive());
  o.w_p = s.Number("w_p", o.w_p, Range::NonNegative());
  o.w_c = s.Number("w_c",
                   o.short_kind == ShortKind::kSolveTime ? 0.0 : kDefaultClearanceWeight,
                   Range::NonNegative());
  o.clearance = s.Number("clearance", o.clearance, Range::Positive());
  o.unit_time = s.Number("unit_time", o.unit_time, Range::Positive());
  const YamlMap l = map.Map("long_term", true);
  l.RejectUnknownKeys({"w_e"});
  o.w_e = l.Number("w_e", o.w_e, Range::NonNegative());
  o.failure_value = map.Number("failure_value", o.failure_value, Range::Positive());
  return o;
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

}  // namespace quadtune::engine
