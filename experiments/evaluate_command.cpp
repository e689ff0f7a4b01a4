// `quadtune evaluate`: flies one parameter point of an experiment on the experiment's own maps —
// a repeat's tuning maps, its race maps, or the held-out maps — scored by the experiment's f_l,
// one CSV row per flight. Tuners outside quadtune (scripts/peers/: Optuna, irace, the oracle
// grid) score their candidates with it, so that every tuner flies the same planner, parameter
// box and maps, and their recommended points fly the held-out maps with the map and flight seeds
// of `quadtune run`'s validation.
#include <spdlog/spdlog.h>

#include <atomic>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "commands.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/experiment/objectives.hpp"
#include "quadtune/engine/tuning/validation.hpp"

namespace quadtune::cli {
namespace {

using engine::ParamValues;

std::atomic<bool> g_evaluate_interrupted{false};
void OnEvaluateSignal(int) { g_evaluate_interrupted.store(true); }

struct EvaluateArgs {
  std::string experiment;
  std::vector<std::string> set;
  std::vector<std::string> params;  ///< NAME=VALUE
  std::string maps = "heldout";
  int repeat = 0;
  int first = 0;
  int count = 1;
  int threads = 0;
  std::string csv;
};

/// The experiment's defaults with the --param values; each name must be a planner parameter and
/// a tuned one must lie inside its bounds (integers integral).
ParamValues Point(const engine::Experiment& e, const std::vector<std::string>& params) {
  ParamValues point = e.Defaults();
  for (const std::string& p : params) {
    const auto eq = p.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw ConfigError("", "--param", "'" + p + "' is not NAME=VALUE");
    }
    const std::string name = p.substr(0, eq);
    const std::string text = p.substr(eq + 1);
    if (!point.count(name)) {
      std::string allowed;
      for (const auto& [k, v] : point) allowed += (allowed.empty() ? "" : ", ") + k;
      throw ConfigError("", "--param", "'" + name + "' is not a parameter of planner '" +
                                           e.planner_type + "'; allowed: " + allowed);
    }
    double value = 0.0;
    std::size_t used = 0;
    try {
      value = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != text.size() || !std::isfinite(value)) {
      throw ConfigError("", "--param", name + ": '" + text + "' is not a finite number");
    }
    for (int i = 0; i < e.space.Dim(); ++i) {
      const auto& q = e.space.At(i);
      if (q.name != name) continue;
      const bool integer = q.type == optimizers::ParameterType::kInteger;
      if (value < q.lower || value > q.upper || (integer && value != std::round(value))) {
        throw ConfigError("", "--param",
                          name + " = " + text + " is outside the experiment's box: " +
                              (integer ? "an integer" : "a number") + " in [" +
                              fmt::format("{}", q.lower) + ", " + fmt::format("{}", q.upper) + "]");
      }
    }
    point[name] = value;
  }
  return point;
}

/// Map k of the chosen kind: its map seed and flight seed.
engine::FlightJob Job(const engine::Experiment& e, const EvaluateArgs& a, const ParamValues& p,
                      int k) {
  engine::FlightJob job;
  job.params = p;
  if (a.maps == "heldout") {
    job.map_seed = e.HeldOutMapSeed(k);
    job.flight_seed = e.HeldOutFlightSeed(k);
  } else if (a.maps == "race") {
    job.map_seed = e.RaceMapSeed(a.repeat, k);
    job.flight_seed = e.RaceFlightSeed(a.repeat, k);
  } else {  // tuning: flight k of repeat `repeat`; the world's seed is evaluate's own
    job.map_seed = e.FlightMapSeed(a.repeat, k);
    job.flight_seed = DeriveSeed(e.seed, {0xe7a1, static_cast<std::uint64_t>(a.repeat),
                                          static_cast<std::uint64_t>(k)});
  }
  return job;
}

/// One CSV line: a text without commas, quotes or line breaks.
std::string CsvField(std::string s) {
  for (char& c : s) {
    if (c == ',' || c == '"' || c == '\n' || c == '\r') c = ';';
  }
  return s;
}

void WriteRows(std::ostream& out, const EvaluateArgs& a, const engine::Experiment& e,
               const std::vector<engine::FlightJob>& jobs,
               const std::vector<engine::FlightRecord>& records) {
  std::set<std::string> term_names;
  std::vector<engine::ObjectiveValue> values;
  for (const auto& r : records) {
    values.push_back(engine::LongTermObjective(r, e.objective));
    for (const auto& [k, v] : values.back().terms) term_names.insert(k);
  }
  out << "maps,repeat,index,map_seed,flight_seed,value,status,message";
  for (const auto& n : term_names) out << ',' << n;
  out << '\n';
  for (std::size_t i = 0; i < records.size(); ++i) {
    out << a.maps << ',' << (a.maps == "heldout" ? -1 : a.repeat) << ','
        << a.first + static_cast<int>(i) << ',' << jobs[i].map_seed << ','
        << jobs[i].flight_seed << ',' << fmt::format("{}", values[i].value) << ','
        << ToString(records[i].status) << ',' << CsvField(records[i].message);
    for (const auto& n : term_names) {
      const auto it = values[i].terms.find(n);
      out << ',' << (it == values[i].terms.end() ? std::string() : fmt::format("{}", it->second));
    }
    out << '\n';
  }
}

int RunEvaluate(const EvaluateArgs& a) {
  const engine::Experiment e = LoadExperiment(a.experiment, a.set);
  if (a.repeat >= e.repeats && a.maps != "heldout") {
    throw ConfigError("", "--repeat",
                      std::to_string(a.repeat) + " is not a repeat of the experiment (it has " +
                          std::to_string(e.repeats) + "; 0 … " + std::to_string(e.repeats - 1) +
                          ")");
  }
  const ParamValues point = Point(e, a.params);
  std::vector<engine::FlightJob> jobs;
  for (int k = a.first; k < a.first + a.count; ++k) jobs.push_back(Job(e, a, point, k));
  std::signal(SIGINT, OnEvaluateSignal);
  std::signal(SIGTERM, OnEvaluateSignal);
  const int threads = a.threads > 0 ? a.threads : e.threads;
  const auto records = engine::FlyJobs(e.planner, jobs, threads, &g_evaluate_interrupted, {});
  if (g_evaluate_interrupted.load()) {
    spdlog::error("evaluate interrupted; nothing written");
    return 130;
  }
  if (a.csv.empty() || a.csv == "-") {
    WriteRows(std::cout, a, e, jobs, records);
    return 0;
  }
  std::ofstream out(a.csv);
  WriteRows(out, a, e, jobs, records);
  if (!out) {
    spdlog::error("{}: --csv: could not be written", a.csv);
    return 1;
  }
  return 0;
}

}  // namespace

void RegisterEvaluate(CLI::App& app, int& exit_code) {
  static EvaluateArgs args;
  auto* cmd = app.add_subcommand(
      "evaluate",
      "fly one parameter point on an experiment's maps (tuning, race or held-out) and print f_l "
      "and its terms per flight as CSV; how tuners outside quadtune score their candidates");
  cmd->add_option("experiment", args.experiment, "experiment file (YAML)")->required();
  cmd->add_option("--param", args.params,
                  "NAME=VALUE: a planner parameter (repeat as needed; the others keep the "
                  "experiment's defaults; tuned ones must lie in the experiment's box)");
  cmd->add_option("--maps", args.maps,
                  "heldout: the validation maps of `quadtune run` (same map and flight seeds); "
                  "tuning: flight k's map of --repeat; race: race map k of --repeat")
      ->capture_default_str()
      ->check(CLI::IsMember({"heldout", "tuning", "race"}));
  cmd->add_option("--repeat", args.repeat, "repeat whose tuning or race maps are flown")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000));
  cmd->add_option("--first", args.first, "first map index k")
      ->capture_default_str()
      ->check(CLI::Range(0, 100000));
  cmd->add_option("--count", args.count, "maps flown: k = first … first + count − 1")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000));
  cmd->add_option("--threads", args.threads, "worker threads (default: the experiment's)")
      ->check(CLI::Range(1, 1024));
  cmd->add_option("--set", args.set,
                  "KEY=VALUE: change the experiment file's dotted KEY (repeat as needed)");
  cmd->add_option("--csv", args.csv, "write the rows to this file (default: standard output)");
  cmd->callback([&exit_code] { exit_code = RunEvaluate(args); });
}

}  // namespace quadtune::cli
