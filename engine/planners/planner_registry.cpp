#include "quadtune/engine/api/planner_registry.hpp"

#include <algorithm>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <utility>

#include "quadtune/engine/planners/planners.hpp"

namespace quadtune::engine {

namespace {

// ---- the built-in planner types ----

Planner BuildIpopt(const YamlMap& p, const std::string& base_dir) {
  return Planner{IpoptPlanner{ClosedLoopOptions::FromYaml(p, base_dir)}};
}

Planner BuildEgo(const YamlMap& p, const std::string& base_dir) {
  ClosedLoopOptions options = ClosedLoopOptions::FromYaml(p, base_dir);
  planning::EgoOptions ego;
  ego.stop_and_go = options.ego_stop_and_go;
  return Planner{EgoPlanner{{std::move(options), ego}}};
}

bool ValidName(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
  });
}

class Registry {
 public:
  Registry() {
    Add("ipopt", BuildIpopt, BackendPlanner::Schema(), [] { return MakeIpoptBackend(); });
    Add("ego", BuildEgo, BackendPlanner::Schema(),
        [] { return std::make_shared<const planning::EgoBackend>(planning::EgoOptions{}); });
  }

  void Add(const std::string& name, PlannerFactory factory, PlannerSchema schema,
           BackendFactory backend = {}) {
    if (!ValidName(name)) {
      throw std::invalid_argument("RegisterPlanner: name '" + name +
                                  "' must be non-empty lower-case letters, digits and '_'");
    }
    if (!factory) throw std::invalid_argument("RegisterPlanner('" + name + "'): empty factory");
    std::set<std::string> seen;
    for (const auto* side : {&schema.short_term, &schema.long_term}) {
      for (const ParameterInfo& p : *side) {
        if (!seen.insert(p.name).second) {
          throw std::invalid_argument("RegisterPlanner('" + name + "'): parameter '" + p.name +
                                      "' named twice in the schema");
        }
      }
    }
    const std::lock_guard lock(mutex_);
    if (types_.count(name)) {
      throw std::invalid_argument("RegisterPlanner: planner type '" + name +
                                  "' is already registered");
    }
    types_.emplace(name,
                   PlannerType{name, std::move(factory), std::move(schema), std::move(backend)});
  }

  std::vector<std::string> Names() const {
    const std::lock_guard lock(mutex_);
    std::vector<std::string> names;
    for (const auto& entry : types_) names.push_back(entry.first);
    return names;
  }

  std::optional<PlannerType> Find(const std::string& name) const {
    const std::lock_guard lock(mutex_);
    const auto it = types_.find(name);
    if (it == types_.end()) return std::nullopt;
    return it->second;
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, PlannerType> types_;  // sorted by name
};

Registry& TheRegistry() {
  static Registry registry;  // the built-ins are in before the first use
  return registry;
}

bool SameRange(const Range& a, const Range& b) {
  return a.lo == b.lo && a.hi == b.hi && a.lo_open == b.lo_open && a.hi_open == b.hi_open;
}

/// Demands that `reported` (a built plug-in's parameters) are `registered` (the schema's), up to
/// the defaults.
void DemandSameSide(const std::string& type, const char* side,
                    const std::vector<ParameterInfo>& registered,
                    const std::vector<ParameterInfo>& reported) {
  bool same = registered.size() == reported.size();
  for (std::size_t i = 0; same && i < registered.size(); ++i) {
    same = registered[i].name == reported[i].name &&
           registered[i].integer == reported[i].integer &&
           SameRange(registered[i].range, reported[i].range);
  }
  QT_DEMAND(same, "planner type '" + type + "': the plug-in its factory built reports " + side +
                      " parameters that differ from the registered schema");
}

}  // namespace

void RegisterPlanner(const std::string& name, PlannerFactory factory, PlannerSchema schema,
                     BackendFactory backend) {
  TheRegistry().Add(name, std::move(factory), std::move(schema), std::move(backend));
}

std::vector<std::string> RegisteredPlanners() { return TheRegistry().Names(); }

std::optional<PlannerType> FindPlanner(const std::string& name) { return TheRegistry().Find(name); }

std::vector<std::string> ClosedLoopPlanners() {
  std::vector<std::string> names;
  for (const std::string& name : RegisteredPlanners()) {
    const std::optional<PlannerType> type = FindPlanner(name);
    if (type && type->backend) names.push_back(name);
  }
  return names;
}

std::shared_ptr<const planning::TrajectoryBackend> BuildClosedLoopBackend(const std::string& name,
                                                                          const std::string& file,
                                                                          const std::string& key) {
  const std::optional<PlannerType> type = FindPlanner(name);
  if (!type || !type->backend) {
    std::string names;
    for (const auto& n : ClosedLoopPlanners()) names += (names.empty() ? "" : ", ") + n;
    throw ConfigError(file, key,
                      "'" + name + "' is not a registered planner flown in the closed loop; " +
                          "registered: " + names);
  }
  return type->backend();
}

BuiltPlanner BuildPlanner(const YamlMap& planner, const std::string& base_dir) {
  const std::string type = planner.String("type", std::string("ipopt"));
  std::optional<PlannerType> entry = FindPlanner(type);
  if (!entry) {
    std::string names;
    for (const auto& n : RegisteredPlanners()) names += (names.empty() ? "" : ", ") + n;
    planner.Fail("type", "unknown planner type '" + type + "'; registered: " + names);
  }
  Planner built = entry->factory(planner, base_dir);
  DemandSameSide(type, "short-term", entry->schema.short_term, built.ShortTermParameters());
  DemandSameSide(type, "long-term", entry->schema.long_term, built.LongTermParameters());
  return {type, std::move(built), std::move(entry->schema)};
}

}  // namespace quadtune::engine
