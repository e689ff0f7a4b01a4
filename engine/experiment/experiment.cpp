#include "quadtune/engine/experiment/experiment.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "field_util.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/engine/api/planner_registry.hpp"

namespace quadtune::engine {

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

std::uint64_t Experiment::RaceMapSeed(int repeat, int index) const {
  return DeriveSeed(seed, {0x7ace, static_cast<std::uint64_t>(repeat), static_cast<std::uint64_t>(index)});
}

std::uint64_t Experiment::RaceFlightSeed(int repeat, int index) const {
  return DeriveSeed(seed, {0x7acf, static_cast<std::uint64_t>(repeat), static_cast<std::uint64_t>(index)});
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
void CheckAgainstSchema(const optimizers::ParameterSpace& space, const PlannerSchema& registered,
                        const std::string& type, const std::string& origin) {
  std::vector<ParameterInfo> schema = registered.short_term;
  schema.insert(schema.end(), registered.long_term.begin(), registered.long_term.end());
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
          s << "got " << v << "; planner '" << type << "' can fly " << prm.name << " only as "
            << allowed;
          throw ConfigError(origin, key + "." + part, s.str());
        }
      };
      check("lower", prm.lower);
      check("upper", prm.upper);
      if (prm.default_value) check("default", *prm.default_value);
      if (info.integer && prm.type != optimizers::ParameterType::kInteger) {
        throw ConfigError(
            origin, key + ".type",
            prm.name + " is an integer parameter of planner '" + type + "'; give type: integer");
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
    const auto m = FromString<Method>(name);
    if (!m) {
      std::string allowed;
      for (const auto& n : EnumNameList<Method>()) allowed += (allowed.empty() ? "" : ", ") + n;
      map.Fail("methods", "unknown method '" + name + "', allowed: " + allowed);
    }
    if (!seen.insert(*m).second) map.Fail("methods", "method '" + name + "' listed twice");
    methods.push_back(*m);
  }
  return methods;
}

// The registered schema of the experiment's planner type (read before the parameters).
PlannerSchema SchemaOf(const Experiment& e) {
  const std::optional<PlannerType> type = FindPlanner(e.planner_type);
  QT_DEMAND(type.has_value(), "planner type '" + e.planner_type + "' is not registered");
  return type->schema;
}

std::set<std::string> NamesOf(const std::vector<ParameterInfo>& side) {
  std::set<std::string> names;
  for (const auto& p : side) names.insert(p.name);
  return names;
}

// Every tuned parameter must be one of the planner's, inside what it can fly.
void CheckParameters(const YamlMap& map, Experiment& e) {
  const PlannerSchema schema = SchemaOf(e);
  const std::set<std::string> planner_short = NamesOf(schema.short_term);
  const std::set<std::string> planner_long = NamesOf(schema.long_term);
  for (const auto& n : e.space.Names()) {
    if (!planner_short.count(n) && !planner_long.count(n)) {
      map.Fail("parameters",
               "'" + n + "' is not a tunable parameter of planner '" + e.planner_type + "'");
    }
  }
  CheckAgainstSchema(e.space, schema, e.planner_type, e.file);
}

// `short_term` or `long_term`: names of the planner's side that have bounds, each once, in space
// order.
std::vector<std::string> ReadSide(const YamlMap& map, const char* key,
                                  const std::vector<ParameterInfo>& side,
                                  const optimizers::ParameterSpace& space) {
  const std::set<std::string> allowed = NamesOf(side);
  const auto space_names = space.Names();
  std::set<std::string> unique;
  for (const auto& n : StringList(map, key)) {
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
  std::vector<std::string> ordered;
  for (const auto& n : space_names) {
    if (unique.count(n)) ordered.push_back(n);
  }
  return ordered;
}

// A point over `names` (`initial_short_term`: all of them; `start`: any of them), each inside its
// bounds; absent key → empty.
std::optional<ParamValues> ReadPoint(const YamlMap& map, const char* key,
                                     const std::vector<std::string>& names, bool all,
                                     const optimizers::ParameterSpace& space) {
  if (!map.Has(key)) return std::nullopt;
  const YamlMap point = map.Map(key);
  point.RejectUnknownKeys(names);
  ParamValues values;
  for (const auto& n : names) {
    if (!all && !point.Has(n)) continue;
    const auto& prm = space.At(space.IndexOf(n));
    values[n] = point.Number(n, std::nullopt, Range::Closed(prm.lower, prm.upper));
  }
  return values;
}

void WriteNames(YAML::Emitter& out, const std::string& key, const std::vector<std::string>& names) {
  out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (const auto& n : names) out << n;
  out << YAML::EndSeq;
}

void WritePoint(YAML::Emitter& out, const std::string& key, const std::optional<ParamValues>& p) {
  if (!p) return;
  out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginMap;
  for (const auto& [name, value] : *p) out << YAML::Key << name << YAML::Value << value;
  out << YAML::EndMap;
}

void WriteParameters(YAML::Emitter& out, const optimizers::ParameterSpace& space) {
  out << YAML::Key << "parameters" << YAML::Value << YAML::BeginSeq;
  for (const auto& p : space.Parameters()) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << p.name << YAML::Key
        << "lower" << YAML::Value << p.lower << YAML::Key << "upper" << YAML::Value << p.upper
        << YAML::Key << "type" << YAML::Value
        << (p.type == optimizers::ParameterType::kInteger ? "integer" : "continuous") << YAML::Key
        << "log" << YAML::Value << p.log_scale;
    if (p.default_value) out << YAML::Key << "default" << YAML::Value << *p.default_value;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
}

// The `budget` section, then its checks against `methods`, `repeats` and `mode`.
void ReadBudget(const YamlMap& map, Experiment& e) {
  const YamlMap b = map.Map("budget", true);
  BudgetFields().Read(b, e.budget);
  // Every trial of every method and repeat: a run that can never finish is refused.
  const double total =
      static_cast<double>(e.budget.flights) * static_cast<double>(e.methods.size()) * e.repeats;
  if (total > kMaxTotalFlights) {
    std::ostringstream s;
    s << "flights × methods × repeats = " << e.budget.flights << " × " << e.methods.size() << " × "
      << e.repeats << " = " << total << " flights; at most " << kMaxTotalFlights << " per run";
    b.Fail("flights", s.str());
  }
  if (e.budget.flight_batch == 0 && e.mode != TimingMode::kRealtime) {
    b.Fail("flight_batch", "0 (one per thread) needs mode: realtime; reproducible runs need a "
                           "fixed batch, an integer in [1, 1024]");
  }
  if (e.budget.short_term_while_flying && e.mode != TimingMode::kRealtime) {
    b.Fail("short_term_while_flying", "true needs mode: realtime (it depends on wall-clock time)");
  }
}

/// `race:`: read, then checked against `recommend:` (racing picks the recommended point).
void ReadRace(const YamlMap& map, Experiment& e) {
  if (!map.Has("race")) return;
  const YamlMap r = map.Map("race");
  optimizers::RaceFields().Read(r, e.race);
  if (e.race.max_maps < e.race.first_maps) {
    r.Fail("max_maps", std::to_string(e.race.max_maps) + " is below first_maps (" +
                           std::to_string(e.race.first_maps) + "); give max_maps >= first_maps");
  }
  if (e.race.propose && e.race.challenger != optimizers::ChallengerRule::kTwoPart) {
    r.Fail("propose", "true needs challenger: two_part (the model that proposes the point)");
  }
  if (e.race.enabled && e.recommend.candidates > 0) {
    r.Fail("enabled", "true hands back the race's incumbent, so recommend.candidates must be 0 "
                      "(it is " + std::to_string(e.recommend.candidates) + ")");
  }
}

}  // namespace

const Fields<MapOptions>& MapsFields() {
  static const Fields<MapOptions> fields =
      Fields<MapOptions>()
          .Choice("mode", &MapOptions::mode,
                  "`per_flight`: every flight on a fresh map of the layout's density; "
                  "`per_repeat`: one map per repeat, flown by every flight of its trials; `pool`: "
                  "flight k flies map k mod `pool` of the repeat. In every mode flight k of every "
                  "method in repeat r flies the same map (common random numbers)")
          .Integer("pool", &MapOptions::pool, Range::Closed(1, 1e6),
                   "`pool` mode: maps per repeat");
  return fields;
}

const Fields<ValidationOptions>& ValidationFields() {
  static const Fields<ValidationOptions> fields = Fields<ValidationOptions>().Integer(
      "maps", &ValidationOptions::maps, Range::Closed(0, 1e5),
      "held-out maps (derived under a seed tag no tuning map uses); each method's recommended "
      "point and the defaults fly all of them at the end of `quadtune run`; 0: no validation. "
      "Studies skip it in their runs and validate themselves (`validation.flights`)");
  return fields;
}

const Fields<RecommendOptions>& RecommendFields() {
  using R = RecommendOptions;
  static const Fields<R> fields =
      Fields<R>()
          .Integer("candidates", &R::candidates, Range::Closed(0, 1000),
                   "candidates tried; 0: no re-flights, the first candidate is recommended")
          .Integer("flights", &R::flights, Range::Closed(1, 1000),
                   "re-flights per candidate, flown `budget.flight_batch` at a time; a candidate "
                   "is dropped at the first batch with a failing flight (unfinished, a collision, "
                   "an emergency stop)")
          .Number("clearance", &R::clearance, Range::Closed(0, 100),
                  "a candidate passes when all its re-flights pass and their smallest clearances "
                  "c keep mean(c) − z·sd(c) ≥ `clearance` (m)")
          .Number("z", &R::z, Range::Closed(0, 10),
                  "the margin's width in standard deviations: under a normal fit of c, a "
                  "collision on a new map has probability below Φ(−z) (2.33: 1%)")
          .Flag("emergency_stops", &R::emergency_stops,
                "false: a re-flight with an emergency stop fails its candidate (most collisions "
                "on new maps follow an emergency stop)")
          .Integer("backoff", &R::backoff, Range::Closed(0, 100),
                   "after the ranked candidates, this many points between the first candidate "
                   "and the defaults: u_d + α (u_best − u_d) in the unit cube of the parameter "
                   "box, α = 1 − i / (backoff + 1), i = 1 … backoff");
  return fields;
}

const Fields<Budget>& BudgetFields() {
  static const Range flights = Range::Closed(1, kMaxFlights);
  static const Fields<Budget> fields =
      Fields<Budget>()
          .Integer("flights", &Budget::flights, flights, "f_l evaluations (flights) per trial")
          .Custom(
              {"default_flights", "integer", "`flights`", DescribeInterval(flights),
               "flights of method `default`"},
              [](const YamlMap& b, Budget& budget) {
                budget.default_flights =
                    static_cast<int>(b.Integer("default_flights", budget.flights, flights));
              },
              [](YAML::Emitter& out, const Budget& budget) {
                out << YAML::Key << "default_flights" << YAML::Value << budget.default_flights;
              })
          .Integer("flight_batch", &Budget::flight_batch, Range::Closed(0, 1024),
                   "flights asked and flown together (fixed, not the thread count); 0 (realtime "
                   "only): one per thread")
          .Integer("short_evals_per_flight", &Budget::short_evals_per_flight,
                   Range::Closed(0, kMaxShortEvalsPerFlight),
                   "θ_s candidates (PSO) scored per flight in `bo_pso`")
          .Integer("queries_per_eval", &Budget::queries_per_eval, Range::Closed(1, 1e4),
                   "recorded planning queries re-solved per θ_s candidate")
          .Integer("query_window", &Budget::query_window, Range::Closed(1, 1e7),
                   "most recent recorded queries kept")
          .Flag("short_term_while_flying", &Budget::short_term_while_flying,
                "realtime only: PSO keeps running generations until the round's flights have "
                "landed");
  return fields;
}

namespace {

/// Adds the keys that name the tuned parameters and their starting points: `parameters`,
/// `short_term`, `long_term`, `initial_short_term`, `start` (read in this order; each reads what
/// the ones before it set).
void AddTunedParameterFields(Fields<Experiment>& fields) {
  using E = Experiment;
  fields
      .Custom(
          {"parameters", "list", "required", "", "the tuned parameters, see below"},
          [](const YamlMap& map, E& e) {
            e.space = optimizers::ParameterSpace::FromYaml(map);
            CheckParameters(map, e);
          },
          [](YAML::Emitter& out, const E& e) { WriteParameters(out, e.space); })
      .Custom(
          {"short_term", "list of names", "required",
           "the planner's short-term parameters (ipopt: `w_col`, `w_dyn`, `n_pol`) that "
           "have bounds in `parameters`",
           "θ_s (PSO in `bo_pso`); every tuned parameter is in exactly one of "
           "`short_term`, `long_term`"},
          [](const YamlMap& map, E& e) {
            e.short_names = ReadSide(map, "short_term", SchemaOf(e).short_term, e.space);
          },
          [](YAML::Emitter& out, const E& e) { WriteNames(out, "short_term", e.short_names); })
      .Custom(
          {"long_term", "list of names", "required",
           "the planner's long-term parameters (ipopt: `v_des`, `h_pl`, `t_pl`) that have "
           "bounds in `parameters`",
           "θ_l (BO in `bo_pso`)"},
          [](const YamlMap& map, E& e) {
            e.long_names = ReadSide(map, "long_term", SchemaOf(e).long_term, e.space);
            if (e.short_names.size() + e.long_names.size() !=
                static_cast<std::size_t>(e.space.Dim())) {
              map.Fail("parameters", "every parameter must be listed in short_term or long_term");
            }
          },
          [](YAML::Emitter& out, const E& e) { WriteNames(out, "long_term", e.long_names); })
      .Custom(
          {"initial_short_term", "map name → number", "absent", "θ_s names, inside their bounds",
           "a given θ_s: `bo_pso` skips its first θ_s phase"},
          [](const YamlMap& map, E& e) {
            e.initial_short =
                ReadPoint(map, "initial_short_term", e.short_names, /*all=*/true, e.space);
          },
          [](YAML::Emitter& out, const E& e) {
            WritePoint(out, "initial_short_term", e.initial_short);
          })
      .Custom(
          {"start", "map name → number", "absent", "tuned names, inside their bounds",
           "a known good point (refinement, paper Sec. III-E): with "
           "`bo.moving_bounds.enabled`, BO begins inside start ± `half_width`; "
           "`bo_pso`'s PSO starts from its θ_s part"},
          [](const YamlMap& map, E& e) {
            e.start = ReadPoint(map, "start", e.space.Names(), /*all=*/false, e.space);
          },
          [](YAML::Emitter& out, const E& e) { WritePoint(out, "start", e.start); });
}

}  // namespace

const Fields<Experiment>& ExperimentFields() {
  using E = Experiment;
  static const Fields<E> fields = [] {
    Fields<E> f;
    f.Text("name", &E::name, {}, "name stored with the results")
        .Integer("seed", &E::seed, Range::Closed(0, 9.0e15),
                 "master seed; every random stream derives from it")
        .Integer("threads", &E::threads, Range::Closed(1, kMaxThreads),
                 "worker threads (`--threads` overrides)")
        .Choice("mode", &E::mode,
                "how solve time t_c is taken: `reproducible` derives it from the solver's "
                "deterministic compute units, so stored results are identical at any thread or "
                "rank count; `realtime` uses wall-clock time, as on board")
        .Integer("repeats", &E::repeats, Range::Closed(1, kMaxRepeats), "trials per method")
        .Custom(
            {"methods", "list", "required", CodeList(EnumNameList<Method>()),
             "methods compared; `bo_pso` is the paper's complementary tuner (BO on θ_l, "
             "PSO on θ_s)"},
            [](const YamlMap& map, E& e) { e.methods = ReadMethods(map); },
            [](YAML::Emitter& out, const E& e) {
              std::vector<std::string> names;
              for (Method m : e.methods) names.emplace_back(ToString(m));
              WriteNames(out, "methods", names);
            })
        .Custom(
            MapDoc("planner", "the planner plug-in and its world, below", "required"),
            [](const YamlMap& map, E& e) {
              BuiltPlanner built = BuildPlanner(map.Map("planner"), e.base_dir);
              e.planner_type = built.type;
              e.planner = built.planner;
            },
            [](YAML::Emitter& out, const E& e) { WriteAsGiven(out, e.text, "planner"); });
    AddTunedParameterFields(f);
    f.Nested("objective", &E::objective, ObjectiveFields(), "weights of f_s and f_l, below")
        .Nested("maps", &E::maps, MapsFields(), "which map each flight flies, below")
        .Nested("validation", &E::validation, ValidationFields(),
                "held-out validation after the trials, below")
        .Nested("recommend", &E::recommend, RecommendFields(),
                "how a trial picks the point it hands back, below")
        .Custom(MapDoc("race", "racing challengers against an incumbent during tuning, below",
                       "see below"),
                ReadRace,
                [](YAML::Emitter& out, const E& e) {
                  out << YAML::Key << "race" << YAML::Value;
                  optimizers::RaceFields().Write(out, e.race);
                })
        .Custom(MapDoc("budget", "budgets of one trial, below", "see below"), ReadBudget,
                [](YAML::Emitter& out, const E& e) {
                  out << YAML::Key << "budget" << YAML::Value;
                  BudgetFields().Write(out, e.budget);
                })
        .Nested("pso", &E::pso, optimizers::PsoFields(),
                "[PSO](#pso) settings (seed derived per trial)")
        .Custom(
            MapDoc("bo",
                   "[Bayesian optimisation](#bayesian-optimisation) settings (seed derived "
                   "per trial)",
                   "see below"),
            [](const YamlMap& map, E& e) {
              if (map.Has("bo")) e.bo = optimizers::BayesOptOptions::FromYaml(map.Map("bo"));
            },
            [](YAML::Emitter& out, const E& e) { WriteAsGiven(out, e.text, "bo"); });
    return f;
  }();
  return fields;
}

Experiment Experiment::FromString(const std::string& text, const std::string& origin,
                                  const std::string& base_dir) {
  Experiment e;
  e.file = origin;
  e.text = text;
  e.base_dir = base_dir;
  ExperimentFields().Read(YamlMap::FromString(text, origin), e);
  return e;
}

}  // namespace quadtune::engine
