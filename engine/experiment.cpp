#include "quadtune/engine/experiment.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "quadtune/common/random.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/engine/planner_registry.hpp"

#ifndef QUADTUNE_SOURCE_DIR
#define QUADTUNE_SOURCE_DIR "."
#endif

namespace quadtune::engine {

const char* ToString(Method method) {
  switch (method) {
    case Method::kDefault: return "default";
    case Method::kRandom: return "random";
    case Method::kPso: return "pso";
    case Method::kBo: return "bo";
    case Method::kBoPso: return "bo_pso";
  }
  return "?";
}

std::optional<Method> MethodFromString(const std::string& name) {
  for (Method m : {Method::kDefault, Method::kRandom, Method::kPso, Method::kBo, Method::kBoPso}) {
    if (name == ToString(m)) return m;
  }
  return std::nullopt;
}

std::string ResolvePath(const std::string& relative, const std::string& base_dir) {
  namespace fs = std::filesystem;
  if (relative.empty() || fs::path(relative).is_absolute()) return relative;
  std::vector<fs::path> candidates{fs::path(base_dir) / relative, fs::path(relative)};
  if (const char* env = std::getenv("QUADTUNE_ASSETS")) candidates.push_back(fs::path(env) / relative);
  candidates.push_back(fs::path(QUADTUNE_SOURCE_DIR) / "assets" / relative);
  for (const auto& c : candidates) {
    if (fs::exists(c)) return c.string();
  }
  return relative;
}

const char* ToString(MapMode mode) {
  switch (mode) {
    case MapMode::kPerFlight: return "per_flight";
    case MapMode::kPerRepeat: return "per_repeat";
    case MapMode::kPool: return "pool";
  }
  return "?";
}

std::uint64_t Experiment::MapSeed(int repeat) const {
  return DeriveSeed(seed, {0x3a9, static_cast<std::uint64_t>(repeat)});
}

std::uint64_t Experiment::FlightMapSeed(int repeat, int flight) const {
  const auto r = static_cast<std::uint64_t>(repeat);
  switch (maps.mode) {
    case MapMode::kPerRepeat: return MapSeed(repeat);
    case MapMode::kPool:
      return DeriveSeed(seed, {0x3a9, r, static_cast<std::uint64_t>(flight % maps.pool)});
    case MapMode::kPerFlight: break;
  }
  return DeriveSeed(seed, {0x3a9, r, static_cast<std::uint64_t>(flight)});
}

std::uint64_t Experiment::RecheckMapSeed(int repeat, int index) const {
  return DeriveSeed(seed, {0x7ec4, static_cast<std::uint64_t>(repeat), static_cast<std::uint64_t>(index)});
}

std::uint64_t Experiment::RecheckFlightSeed(int repeat, int index) const {
  return DeriveSeed(seed, {0x7ec5, static_cast<std::uint64_t>(repeat), static_cast<std::uint64_t>(index)});
}

std::uint64_t Experiment::HeldOutMapSeed(int index) const {
  return DeriveSeed(seed, {0x4e1d, static_cast<std::uint64_t>(index)});
}

std::uint64_t Experiment::HeldOutFlightSeed(int index) const {
  return DeriveSeed(seed, {0x4e1e, static_cast<std::uint64_t>(index)});
}

namespace {

std::vector<std::string> StringList(const YamlMap& map, const std::string& key) {
  const YAML::Node node = map.node()[key];
  if (!node || !node.IsSequence() || node.size() == 0) {
    map.Fail(key, "expected a non-empty list of names");
  }
  std::vector<std::string> out;
  for (const auto& item : node) {
    if (!item.IsScalar()) map.Fail(key, "expected a list of names");
    out.push_back(item.as<std::string>());
  }
  return out;
}

/// Every tuning box must lie inside what the planner type can fly (its registered schema), and an
/// integer parameter of the planner must be tuned as an integer.
void CheckAgainstSchema(const optimizers::ParameterSpace& space, const BuiltPlanner& planner,
                        const std::string& origin) {
  std::vector<ParameterInfo> schema = planner.schema.short_term;
  schema.insert(schema.end(), planner.schema.long_term.begin(), planner.schema.long_term.end());
  for (int i = 0; i < space.Dim(); ++i) {
    const auto& prm = space.At(i);
    const std::string key = "parameters." + std::to_string(i);
    for (const ParameterInfo& info : schema) {
      if (info.name != prm.name) continue;
      const std::string described = info.range.Describe();
      const std::size_t bracket = described.find_first_of("[(");
      const std::string allowed =
          bracket == std::string::npos
              ? described
              : (info.integer ? "an integer in " : "a number in ") + described.substr(bracket);
      const auto check = [&](const char* part, double v) {
        if (!info.range.Contains(v)) {
          std::ostringstream s;
          s << "got " << v << "; planner '" << planner.type << "' can fly " << prm.name
            << " only as " << allowed;
          throw ConfigError(origin, key + "." + part, s.str());
        }
      };
      check("lower", prm.lower);
      check("upper", prm.upper);
      if (prm.default_value) check("default", *prm.default_value);
      if (info.integer && prm.type != optimizers::ParameterType::kInteger) {
        throw ConfigError(origin, key + ".type",
                          prm.name + " is an integer parameter of planner '" + planner.type +
                              "'; give type: integer");
      }
    }
  }
}

}  // namespace

ParamValues Experiment::Defaults() const {
  ParamValues d = planner.Defaults();
  for (const auto& p : space.Parameters()) {
    if (p.default_value) d[p.name] = *p.default_value;
  }
  return d;
}

Experiment Experiment::LoadFile(const std::string& path) { return LoadFile(path, {}); }

Experiment Experiment::LoadFile(const std::string& path,
                                const std::vector<std::string>& assignments) {
  const std::string text = ReadFileText(path);
  const std::string dir = std::filesystem::path(path).parent_path().string();
  return FromString(ApplyAssignments(text, assignments, path), path, dir.empty() ? "." : dir);
}

namespace {

// The `methods` list: known names, each once.
std::vector<Method> ReadMethods(const YamlMap& map) {
  std::vector<Method> methods;
  std::set<Method> seen;
  for (const auto& name : StringList(map, "methods")) {
    const auto m = MethodFromString(name);
    if (!m) {
      map.Fail("methods",
               "unknown method '" + name + "', allowed: default, random, pso, bo, bo_pso");
    }
    if (!seen.insert(*m).second) map.Fail("methods", "method '" + name + "' listed twice");
    methods.push_back(*m);
  }
  return methods;
}

// Which parameters are short- and long-term (each must be the planner's and in e.space), and
// the optional `initial_short_term` and `start` points.
void ReadParameterRoles(const YamlMap& map, const BuiltPlanner& built, const std::string& origin,
                        Experiment& e) {
  std::set<std::string> planner_short, planner_long;
  for (const auto& p : built.schema.short_term) planner_short.insert(p.name);
  for (const auto& p : built.schema.long_term) planner_long.insert(p.name);
  const auto space_names = e.space.Names();
  for (const auto& n : space_names) {
    if (!planner_short.count(n) && !planner_long.count(n)) {
      map.Fail("parameters", "'" + n + "' is not a tunable parameter of planner '" +
                                 built.type + "'");
    }
  }
  CheckAgainstSchema(e.space, built, origin);
  auto read_side = [&](const char* key, const std::set<std::string>& allowed) {
    std::vector<std::string> names = StringList(map, key);
    std::set<std::string> unique;
    for (const auto& n : names) {
      if (!allowed.count(n)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        map.Fail(key, "'" + n + "' is not allowed here; allowed: " + list);
      }
      if (std::find(space_names.begin(), space_names.end(), n) == space_names.end()) {
        map.Fail(key, "'" + n + "' has no bounds in parameters");
      }
      if (!unique.insert(n).second) map.Fail(key, "'" + n + "' listed twice");
    }
    // Keep space order.
    std::vector<std::string> ordered;
    for (const auto& n : space_names) {
      if (unique.count(n)) ordered.push_back(n);
    }
    return ordered;
  };
  e.short_names = read_side("short_term", planner_short);
  e.long_names = read_side("long_term", planner_long);
  if (e.short_names.size() + e.long_names.size() != space_names.size()) {
    map.Fail("parameters", "every parameter must be listed in short_term or long_term");
  }
  if (map.Has("initial_short_term")) {
    const YamlMap init = map.Map("initial_short_term");
    init.RejectUnknownKeys(e.short_names);
    ParamValues values;
    for (const auto& n : e.short_names) {
      const auto& prm = e.space.At(e.space.IndexOf(n));
      values[n] = init.Number(n, std::nullopt, Range::Closed(prm.lower, prm.upper));
    }
    e.initial_short = values;
  }
  if (map.Has("start")) {
    const YamlMap start = map.Map("start");
    start.RejectUnknownKeys(space_names);
    ParamValues values;
    for (const auto& n : space_names) {
      if (!start.Has(n)) continue;
      const auto& prm = e.space.At(e.space.IndexOf(n));
      values[n] = start.Number(n, std::nullopt, Range::Closed(prm.lower, prm.upper));
    }
    e.start = values;
  }
}

// The `maps`, `validation` and `recommend` sections.
void ReadMapsAndValidation(const YamlMap& map, Experiment& e) {
  const YamlMap m = map.Map("maps", true);
  m.RejectUnknownKeys({"mode", "pool"});
  const std::string mode =
      m.String("mode", std::string(ToString(e.maps.mode)), {"per_flight", "per_repeat", "pool"});
  for (MapMode candidate : {MapMode::kPerFlight, MapMode::kPerRepeat, MapMode::kPool}) {
    if (mode == ToString(candidate)) e.maps.mode = candidate;
  }
  e.maps.pool = static_cast<int>(m.Integer("pool", e.maps.pool, Range::Closed(1, 1e6)));
  const YamlMap v = map.Map("validation", true);
  v.RejectUnknownKeys({"maps"});
  e.validation.maps = static_cast<int>(v.Integer("maps", e.validation.maps, Range::Closed(0, 1e5)));
  const YamlMap r = map.Map("recommend", true);
  r.RejectUnknownKeys({"candidates", "flights", "clearance", "z", "emergency_stops", "backoff"});
  e.recommend.candidates =
      static_cast<int>(r.Integer("candidates", e.recommend.candidates, Range::Closed(0, 1000)));
  e.recommend.flights =
      static_cast<int>(r.Integer("flights", e.recommend.flights, Range::Closed(1, 1000)));
  e.recommend.clearance = r.Number("clearance", e.recommend.clearance, Range::Closed(0, 100));
  e.recommend.z = r.Number("z", e.recommend.z, Range::Closed(0, 10));
  e.recommend.emergency_stops = r.Bool("emergency_stops", e.recommend.emergency_stops);
  e.recommend.backoff =
      static_cast<int>(r.Integer("backoff", e.recommend.backoff, Range::Closed(0, 100)));
}

// The `budget` section (after `methods`, `repeats` and `mode`, which bound it).
void ReadBudget(const YamlMap& map, Experiment& e) {
  const YamlMap b = map.Map("budget", true);
  b.RejectUnknownKeys({"flights", "default_flights", "flight_batch", "short_evals_per_flight", "queries_per_eval",
                       "query_window", "short_term_while_flying"});
  e.budget.flights =
      static_cast<int>(b.Integer("flights", e.budget.flights, Range::Closed(1, kMaxFlights)));
  e.budget.default_flights = static_cast<int>(
      b.Integer("default_flights", e.budget.flights, Range::Closed(1, kMaxFlights)));
  {
    // Every trial of every method and repeat: a run that can never finish is refused.
    const double total = static_cast<double>(e.budget.flights) *
                         static_cast<double>(e.methods.size()) * e.repeats;
    if (total > kMaxTotalFlights) {
      std::ostringstream s;
      s << "flights × methods × repeats = " << e.budget.flights << " × " << e.methods.size()
        << " × " << e.repeats << " = " << total << " flights; at most " << kMaxTotalFlights
        << " per run";
      b.Fail("flights", s.str());
    }
  }
  e.budget.flight_batch =
      static_cast<int>(b.Integer("flight_batch", e.budget.flight_batch, Range::Closed(0, 1024)));
  if (e.budget.flight_batch == 0 && e.mode != TimingMode::kRealtime) {
    b.Fail("flight_batch", "0 (one per thread) needs mode: realtime; reproducible runs need a "
                           "fixed batch, an integer in [1, 1024]");
  }
  e.budget.short_evals_per_flight = static_cast<int>(
      b.Integer("short_evals_per_flight", e.budget.short_evals_per_flight,
                Range::Closed(0, kMaxShortEvalsPerFlight)));
  e.budget.queries_per_eval = static_cast<int>(
      b.Integer("queries_per_eval", e.budget.queries_per_eval, Range::Closed(1, 1e4)));
  e.budget.query_window =
      static_cast<int>(b.Integer("query_window", e.budget.query_window, Range::Closed(1, 1e7)));
  e.budget.short_term_while_flying = b.Bool("short_term_while_flying", false);
  if (e.budget.short_term_while_flying && e.mode != TimingMode::kRealtime) {
    b.Fail("short_term_while_flying", "true needs mode: realtime (it depends on wall-clock time)");
  }
}

}  // namespace

Experiment Experiment::FromString(const std::string& text, const std::string& origin,
                                  const std::string& base_dir) {
  const YamlMap map = YamlMap::FromString(text, origin);
  map.RejectUnknownKeys({"name", "seed", "threads", "mode", "repeats", "methods", "planner",
                         "parameters", "short_term", "long_term", "initial_short_term", "start",
                         "objective", "maps", "validation", "recommend", "budget", "pso", "bo"});
  Experiment e;
  e.file = origin;
  e.text = text;
  e.name = map.String("name", std::string("experiment"));
  e.seed = static_cast<std::uint64_t>(map.Integer("seed", 1, Range::Closed(0, 9.0e15)));
  e.threads = static_cast<int>(map.Integer("threads", 2, Range::Closed(1, 1024)));
  e.mode =
      map.String("mode", std::string("reproducible"), {"reproducible", "realtime"}) == "realtime"
          ? TimingMode::kRealtime
          : TimingMode::kReproducible;
  e.repeats = static_cast<int>(map.Integer("repeats", 1, Range::Closed(1, kMaxRepeats)));
  e.methods = ReadMethods(map);
  BuiltPlanner built = BuildPlanner(map.Map("planner"), base_dir);
  e.planner_type = built.type;
  e.planner = built.planner;
  e.space = optimizers::ParameterSpace::FromYaml(map);
  ReadParameterRoles(map, built, origin, e);
  e.objective = ObjectiveOptions::FromYaml(map.Map("objective", true));
  e.objective.Validate(origin);
  ReadMapsAndValidation(map, e);
  ReadBudget(map, e);
  if (map.Has("pso")) e.pso = optimizers::PsoOptions::FromYaml(map.Map("pso"));
  if (map.Has("bo")) e.bo = optimizers::BayesOptOptions::FromYaml(map.Map("bo"));
  return e;
}

}  // namespace quadtune::engine
