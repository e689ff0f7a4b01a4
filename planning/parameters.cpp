#include "quadtune/planning/parameters.hpp"

#include <cmath>
#include <limits>

#include "quadtune/planning/parameter_schema.hpp"

namespace quadtune::planning {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// One row per parameter, in reference order: name, member (real or integer), allowed range,
/// role and meaning. The single table behind the field list, named access and the schema.
struct Row {
  const char* name;
  double PlannerParams::*real;
  int PlannerParams::*integer;
  Range range;
  ParameterRole role;
  const char* meaning;
};

const std::vector<Row>& Rows() {
  using P = PlannerParams;
  using R = ParameterRole;
  static const std::vector<Row> rows = {
      {"w_col", &P::w_col, nullptr, Range::Positive(), R::kShortTerm,
       "collision-penalty weight (relative to jerk energy)"},
      {"w_dyn", &P::w_dyn, nullptr, Range::Positive(), R::kShortTerm,
       "dynamic-feasibility penalty weight"},
      {"n_pol", nullptr, &P::n_pol, Range::Closed(2, 12), R::kShortTerm,
       "polynomial pieces of a local trajectory"},
      {"v_des", &P::v_des, nullptr, Range{0.0, 15.0, true, false}, R::kLongTerm,
       "desired (maximum) velocity (m/s)"},
      {"h_pl", &P::h_pl, nullptr, Range::Closed(1.0, 30.0), R::kLongTerm,
       "planning horizon: distance to the local goal (m)"},
      {"t_pl", &P::t_pl, nullptr, Range::Closed(0.05, 10.0), R::kLongTerm, "re-plan interval (s)"},
      {"a_max", &P::a_max, nullptr, Range::Positive(), R::kFixed, "acceleration limit (m/s²)"},
      {"clearance", &P::clearance, nullptr, Range::Positive(), R::kFixed,
       "desired clearance in the collision cost (soft) (m); below the distance field's 1 m "
       "truncation (`esdf.max_distance`)"},
      {"inflation", &P::inflation, nullptr, Range::NonNegative(), R::kFixed,
       "safety radius: the map is inflated by it and accepted plans keep it (m)"},
      {"tau_c", &P::tau_c, nullptr, Range::Positive(), R::kFixed,
       "emergency stop if a collision is predicted within it (s)"},
      {"goal_tolerance", &P::goal_tolerance, nullptr, Range::Positive(), R::kFixed,
       "waypoint reached within it (m)"},
      {"no_replan_near_goal", &P::no_replan_near_goal, nullptr, Range::NonNegative(), R::kFixed,
       "no periodic re-plan this close to the goal (m)"},
      {"map_resolution", &P::map_resolution, nullptr, Range{0.0, 1.0, true, false}, R::kFixed,
       "occupancy and distance-field voxel size (m)"},
      {"w_smooth", &P::w_smooth, nullptr, Range::Positive(), R::kFixed, "jerk-energy weight"},
      {"w_time", &P::w_time, nullptr, Range::NonNegative(), R::kFixed,
       "weight of slowing below the nominal time allocation at v_des (1/s)"},
      {"max_attempts", nullptr, &P::max_attempts, Range{1.0, kInf, false, false}, R::kFixed,
       "planning attempts per re-plan before it counts as failed"},
  };
  return rows;
}

const Row& Find(const std::string& name) {
  for (const Row& r : Rows()) {
    if (name == r.name) return r;
  }
  std::string allowed;
  for (const Row& r : Rows()) allowed += (allowed.empty() ? "" : ", ") + std::string(r.name);
  throw ConfigError("", name, "unknown planner parameter; allowed: " + allowed);
}

std::vector<std::string> NamesOf(ParameterRole role) {
  std::vector<std::string> names;
  for (const Row& r : Rows()) {
    if (r.role == role) names.emplace_back(r.name);
  }
  return names;
}

// The reference's meaning: role first ("θ_s: ...", "θ_l: ...", "fixed: ...").
std::string DocMeaning(const Row& r) {
  const char* role = r.role == ParameterRole::kShortTerm  ? "θ_s"
                     : r.role == ParameterRole::kLongTerm ? "θ_l"
                                                          : "fixed";
  return std::string(role) + ": " + r.meaning;
}

}  // namespace

const Fields<PlannerParams>& PlannerParamsFields() {
  static const Fields<PlannerParams> fields = [] {
    Fields<PlannerParams> f;
    for (const Row& r : Rows()) {
      if (r.real != nullptr) {
        f.Number(r.name, r.real, r.range, DocMeaning(r));
      } else {
        f.Integer(r.name, r.integer, r.range, DocMeaning(r));
      }
    }
    return f;
  }();
  return fields;
}

const std::vector<PlannerParameterInfo>& PlannerParameterSchema() {
  static const std::vector<PlannerParameterInfo> schema = [] {
    const PlannerParams defaults;
    std::vector<PlannerParameterInfo> out;
    for (const Row& r : Rows()) {
      out.push_back(
          {r.name, r.role, r.integer != nullptr, r.range, defaults.Get(r.name), r.meaning});
    }
    return out;
  }();
  return schema;
}

const std::vector<std::string>& PlannerParams::ShortTermNames() {
  static const std::vector<std::string> names = NamesOf(ParameterRole::kShortTerm);
  return names;
}

const std::vector<std::string>& PlannerParams::LongTermNames() {
  static const std::vector<std::string> names = NamesOf(ParameterRole::kLongTerm);
  return names;
}

const std::vector<std::string>& PlannerParams::TunableNames() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> all = ShortTermNames();
    all.insert(all.end(), LongTermNames().begin(), LongTermNames().end());
    return all;
  }();
  return names;
}

Range ParameterRange(const std::string& name) { return Find(name).range; }

bool ParameterIsInteger(const std::string& name) { return Find(name).integer != nullptr; }

double PlannerParams::Get(const std::string& name) const {
  const Row& r = Find(name);
  return r.real != nullptr ? this->*(r.real) : static_cast<double>(this->*(r.integer));
}

void PlannerParams::Set(const std::string& name, double value) {
  const Row& r = Find(name);
  if (r.real != nullptr) {
    this->*(r.real) = value;
  } else {
    this->*(r.integer) = static_cast<int>(std::lround(value));
  }
}

void PlannerParams::Validate(const std::string& origin) const {
  PlannerParamsFields().Check(*this, origin);
}

PlannerParams PlannerParams::FromYaml(const YamlMap& map) {
  return PlannerParamsFields().Read(map);
}

}  // namespace quadtune::planning
