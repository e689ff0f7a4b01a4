#include "quadtune/planning/parameters.hpp"

#include "quadtune/planning/parameter_schema.hpp"

#include <cmath>
#include <limits>

namespace quadtune::planning {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// One row per parameter: name, member accessor, allowed range, integer or not.
struct Field {
  const char* name;
  double PlannerParams::*real;
  int PlannerParams::*integer;
  Range range;
};

const std::vector<Field>& Fields() {
  static const std::vector<Field> fields = {
      {"w_col", &PlannerParams::w_col, nullptr, Range::Positive()},
      {"w_dyn", &PlannerParams::w_dyn, nullptr, Range::Positive()},
      {"n_pol", nullptr, &PlannerParams::n_pol, Range::Closed(2, 12)},
      {"v_des", &PlannerParams::v_des, nullptr, {0.0, 15.0, true, false}},
      {"h_pl", &PlannerParams::h_pl, nullptr, Range::Closed(1.0, 30.0)},
      {"t_pl", &PlannerParams::t_pl, nullptr, Range::Closed(0.05, 10.0)},
      {"a_max", &PlannerParams::a_max, nullptr, Range::Positive()},
      {"clearance", &PlannerParams::clearance, nullptr, Range::Positive()},
      {"inflation", &PlannerParams::inflation, nullptr, Range::NonNegative()},
      {"tau_c", &PlannerParams::tau_c, nullptr, Range::Positive()},
      {"goal_tolerance", &PlannerParams::goal_tolerance, nullptr, Range::Positive()},
      {"no_replan_near_goal", &PlannerParams::no_replan_near_goal, nullptr, Range::NonNegative()},
      {"map_resolution", &PlannerParams::map_resolution, nullptr, {0.0, 1.0, true, false}},
      {"w_smooth", &PlannerParams::w_smooth, nullptr, Range::Positive()},
      {"w_time", &PlannerParams::w_time, nullptr, Range::NonNegative()},
      {"max_attempts", nullptr, &PlannerParams::max_attempts, {1.0, kInf, false, false}},
  };
  return fields;
}

const Field* Find(const std::string& name) {
  for (const auto& f : Fields()) {
    if (name == f.name) return &f;
  }
  return nullptr;
}

std::vector<std::string> AllNames() {
  std::vector<std::string> names;
  for (const auto& f : Fields()) names.emplace_back(f.name);
  return names;
}

[[noreturn]] void Unknown(const std::string& name) {
  std::string allowed;
  for (const auto& n : AllNames()) allowed += (allowed.empty() ? "" : ", ") + n;
  throw ConfigError("", name, "unknown planner parameter; allowed: " + allowed);
}

}  // namespace

const std::vector<std::string>& PlannerParams::ShortTermNames() {
  static const std::vector<std::string> names = {"w_col", "w_dyn", "n_pol"};
  return names;
}

const std::vector<std::string>& PlannerParams::LongTermNames() {
  static const std::vector<std::string> names = {"v_des", "h_pl", "t_pl"};
  return names;
}

const std::vector<std::string>& PlannerParams::TunableNames() {
  static const std::vector<std::string> names = {"w_col", "w_dyn", "n_pol",
                                                 "v_des", "h_pl",  "t_pl"};
  return names;
}

Range ParameterRange(const std::string& name) {
  const Field* f = Find(name);
  if (f == nullptr) Unknown(name);
  return f->range;
}

bool ParameterIsInteger(const std::string& name) {
  const Field* f = Find(name);
  if (f == nullptr) Unknown(name);
  return f->integer != nullptr;
}

double PlannerParams::Get(const std::string& name) const {
  const Field* f = Find(name);
  if (f == nullptr) Unknown(name);
  return f->real != nullptr ? this->*(f->real) : static_cast<double>(this->*(f->integer));
}

void PlannerParams::Set(const std::string& name, double value) {
  const Field* f = Find(name);
  if (f == nullptr) Unknown(name);
  if (f->real != nullptr) {
    this->*(f->real) = value;
  } else {
    this->*(f->integer) = static_cast<int>(std::lround(value));
  }
}

void PlannerParams::Validate(const std::string& origin) const {
  for (const auto& f : Fields()) {
    CheckInRange(Get(f.name), f.range, origin, f.name);
  }
}

PlannerParams PlannerParams::FromYaml(const YamlMap& map) {
  map.RejectUnknownKeys(AllNames());
  PlannerParams p;
  for (const auto& f : Fields()) {
    if (!map.Has(f.name)) continue;
    if (f.real != nullptr) {
      p.*(f.real) = map.Number(f.name, std::nullopt, f.range);
    } else {
      p.*(f.integer) = static_cast<int>(map.Integer(f.name, std::nullopt, f.range));
    }
  }
  return p;
}

}  // namespace quadtune::planning
