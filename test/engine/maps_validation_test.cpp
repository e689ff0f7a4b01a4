// Maps per flight with common random numbers, the held-out validation, the recommended points
// and the discount count n_d (engine/tuning/tuner.cpp, engine/tuning/validation.cpp).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>
#include <vector>

#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "test_util.hpp"

namespace quadtune::engine {
namespace {

/// Long-term rows per (method, repeat), in flight order (iteration, index).
std::map<std::pair<std::string, int>, std::vector<EvaluationRow>> LongRows(
    const std::string& store_path) {
  ResultStore store(store_path);
  std::map<std::int64_t, int> repeat_of;
  for (const auto& t : store.Trials()) repeat_of[t.id] = t.repeat;
  std::map<std::pair<std::string, int>, std::vector<EvaluationRow>> rows;
  for (const auto& r : store.Evaluations()) {
    if (r.kind == EvalKind::kLong) {
      rows[{ToString(r.method), repeat_of.at(r.trial_id)}].push_back(r);
    }
  }
  return rows;
}

std::string WithMaps(const std::string& yaml, const std::string& maps) {
  return yaml + "maps: " + maps + "\n";
}

TEST(MapsPerFlight, EveryFlightFliesAFreshMapAndFlightKOfEveryMethodTheSameOne) {
  const std::string dir = test::TempDir("maps_per_flight");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  std::string yaml = test::ToyYaml("[default, random, pso, bo, bo_pso]", "", 6, 0);
  yaml.replace(yaml.find("repeats: 1"), 10, "repeats: 2");
  const Experiment e = Experiment::FromString(yaml, "toy.yaml");
  ASSERT_EQ(e.maps.mode, MapMode::kPerFlight);
  ASSERT_EQ(RunExperiment(e, o).status, RunStatus::kCompleted);
  const auto rows = LongRows(o.store_path);
  ASSERT_EQ(rows.size(), 10u);  // 5 methods × 2 repeats
  std::map<int, std::vector<std::uint64_t>> reference;  // repeat → map seeds of flight k
  std::set<std::uint64_t> all_repeats;
  for (const auto& [key, trial] : rows) {
    const auto& [method, repeat] = key;
    ASSERT_EQ(trial.size(), 6u) << method;
    std::vector<std::uint64_t> seeds;
    for (const auto& r : trial) seeds.push_back(r.map_seed);
    // Distinct maps within a trial, the default baseline included.
    EXPECT_EQ(std::set<std::uint64_t>(seeds.begin(), seeds.end()).size(), seeds.size()) << method;
    for (std::size_t k = 0; k < seeds.size(); ++k) {
      EXPECT_EQ(seeds[k], e.FlightMapSeed(repeat, static_cast<int>(k))) << method << " " << k;
      EXPECT_NE(trial[k].flight_seed, 0u);
    }
    // Paired across methods: flight k of every method in one repeat flies the same map.
    if (!reference.count(repeat)) reference[repeat] = seeds;
    EXPECT_EQ(seeds, reference[repeat]) << method << " repeat " << repeat;
    all_repeats.insert(seeds.begin(), seeds.end());
  }
  // The two repeats fly different maps.
  EXPECT_EQ(all_repeats.size(), 12u);
}

TEST(MapsPerFlight, PerRepeatAndPoolModesReuseMaps) {
  const std::string base = test::ToyYaml("[random]", "", 6, 0);
  {
    const Experiment e = Experiment::FromString(WithMaps(base, "{mode: per_repeat}"), "t.yaml");
    EXPECT_EQ(e.FlightMapSeed(0, 0), e.MapSeed(0));
    EXPECT_EQ(e.FlightMapSeed(0, 5), e.MapSeed(0));
    EXPECT_NE(e.FlightMapSeed(1, 0), e.MapSeed(0));
  }
  {
    const Experiment e = Experiment::FromString(WithMaps(base, "{mode: pool, pool: 3}"), "t.yaml");
    EXPECT_EQ(e.FlightMapSeed(0, 4), e.FlightMapSeed(0, 1));
    EXPECT_NE(e.FlightMapSeed(0, 2), e.FlightMapSeed(0, 1));
    const std::string dir = test::TempDir("maps_pool");
    RunOptions o;
    o.store_path = dir + "/r.sqlite";
    ASSERT_EQ(RunExperiment(e, o).status, RunStatus::kCompleted);
    std::set<std::uint64_t> seeds;
    const auto rows = LongRows(o.store_path);
    for (const auto& r : rows.at({"random", 0})) seeds.insert(r.map_seed);
    EXPECT_EQ(seeds.size(), 3u);
  }
}

TEST(MapsPerFlight, BadMapsKeysNameTheKey) {
  const std::string base = test::ToyYaml("[random]", "", 6, 0);
  try {
    (void)Experiment::FromString(WithMaps(base, "{mode: sometimes}"), "m.yaml");
    FAIL() << "accepted an unknown maps.mode";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("mode"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("per_flight"), std::string::npos) << e.what();
  }
  try {
    (void)Experiment::FromString(WithMaps(base, "{mode: pool, pool: 0}"), "m.yaml");
    FAIL() << "accepted an empty pool";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("pool"), std::string::npos) << e.what();
  }
}

TEST(Validation, HeldOutMapsAreDisjointFromTuningMapsAndSharedByEveryPoint) {
  const std::string dir = test::TempDir("validation");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  const Experiment e =
      Experiment::FromString(test::ToyYaml("[default, random, bo, bo_pso]", "", 6, 4), "t.yaml");
  const RunSummary s = RunExperiment(e, o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  // The defaults first, then one recommended point per trial; each on the 4 maps.
  ASSERT_EQ(s.validation.size(), 5u);
  EXPECT_EQ(s.validation[0].method, "default");
  EXPECT_EQ(s.validation[0].params, e.Defaults());
  for (const auto& v : s.validation) EXPECT_EQ(v.flights, 4) << v.method;
  // The `default` trial recommends the defaults and reuses their flights.
  EXPECT_EQ(s.validation[1].method, "default");
  EXPECT_EQ(s.validation[1].mean_value, s.validation[0].mean_value);

  ResultStore store(o.store_path);
  std::set<std::uint64_t> tuning;
  std::map<std::int64_t, std::vector<std::uint64_t>> held_out;  // trial → map seeds by map
  std::map<std::int64_t, std::vector<std::uint64_t>> flight_seeds;
  for (const auto& r : store.Evaluations()) {
    if (r.kind == EvalKind::kLong) tuning.insert(r.map_seed);
    if (r.kind == EvalKind::kValidation) {
      held_out[r.trial_id].push_back(r.map_seed);
      flight_seeds[r.trial_id].push_back(r.flight_seed);
    }
  }
  ASSERT_EQ(tuning.size(), 6u);  // flight k of every method flies map k
  // Stored: the defaults (trial id 0) and the three tuned trials; not the `default` trial.
  ASSERT_EQ(held_out.size(), 4u);
  ASSERT_TRUE(held_out.count(0));
  for (const auto& [trial, seeds] : held_out) {
    ASSERT_EQ(seeds.size(), 4u);
    EXPECT_EQ(seeds, held_out.at(0)) << "trial " << trial << " flew other held-out maps";
    EXPECT_EQ(flight_seeds.at(trial), flight_seeds.at(0)) << "trial " << trial;
    for (std::size_t v = 0; v < seeds.size(); ++v) {
      EXPECT_EQ(seeds[v], e.HeldOutMapSeed(static_cast<int>(v)));
      EXPECT_FALSE(tuning.count(seeds[v])) << "held-out map " << v << " was a tuning map";
    }
  }
  EXPECT_EQ(std::set<std::uint64_t>(held_out.at(0).begin(), held_out.at(0).end()).size(), 4u);
}

TEST(Validation, ProgressComesOneFlightAtATimeCountingUp) {
  // The held-out flights fly on several threads; the progress callback (the CLI's progress line
  // and ETA estimator, which are not thread-safe) must get one call at a time, counting up.
  RunOptions o;
  o.threads = 4;
  std::atomic<int> inside{0};
  std::atomic<int> overlaps{0};
  std::mutex seen_mutex;
  std::vector<int> seen;
  o.on_progress = [&](const Progress& p) {
    if (p.method != "validation") return;
    if (inside.fetch_add(1) != 0) overlaps.fetch_add(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(3));  // a slow printer
    {
      const std::lock_guard<std::mutex> lock(seen_mutex);
      seen.push_back(p.flights_done);
    }
    inside.fetch_sub(1);
  };
  const Experiment e = Experiment::FromString(
      test::ToyYaml("[default, random]", ", flight_delay_s: 0.003", 4, 8), "t.yaml");
  ASSERT_EQ(RunExperiment(e, o).status, RunStatus::kCompleted);
  EXPECT_EQ(overlaps.load(), 0);
  ASSERT_GE(seen.size(), 16u);  // the defaults and random's point, 8 maps each
  for (std::size_t k = 0; k < seen.size(); ++k) EXPECT_EQ(seen[k], static_cast<int>(k) + 1);
}

TEST(Validation, ResumedRunReplaysStoredValidationAndGivesTheSameSummary) {
  const std::string dir = test::TempDir("validation_resume");
  const Experiment e =
      Experiment::FromString(test::ToyYaml("[random, bo_pso]", "", 4, 3), "t.yaml");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  const RunSummary first = RunExperiment(e, o);
  ASSERT_EQ(first.status, RunStatus::kCompleted);
  o.resume = true;
  const RunSummary again = RunExperiment(e, o);
  ASSERT_EQ(again.status, RunStatus::kCompleted);
  EXPECT_EQ(again.flights, 0);  // nothing flown twice: trials and validation replayed
  ASSERT_EQ(again.validation.size(), first.validation.size());
  for (std::size_t i = 0; i < first.validation.size(); ++i) {
    EXPECT_EQ(again.validation[i].mean_value, first.validation[i].mean_value);
    EXPECT_EQ(again.validation[i].params, first.validation[i].params);
  }
}

TEST(Recommendation, BoRecommendsAnObservedPointAndDefaultTheDefaults) {
  const std::string dir = test::TempDir("recommend");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  const Experiment e =
      Experiment::FromString(test::ToyYaml("[default, bo, bo_pso]", "", 8, 0), "t.yaml");
  const RunSummary s = RunExperiment(e, o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  ResultStore store(o.store_path);
  std::map<std::string, std::vector<std::string>> observed;  // method → params JSON of flights
  for (const auto& r : store.Evaluations()) {
    if (r.kind == EvalKind::kLong) observed[ToString(r.method)].push_back(r.params);
  }
  for (const auto& t : s.trials) {
    nlohmann::json j = nlohmann::json::object();
    for (const auto& [k, v] : t.recommended) j[k] = v;
    if (t.method == "default") {
      EXPECT_EQ(t.recommended, e.Defaults());
      continue;
    }
    ASSERT_FALSE(t.recommended.empty()) << t.method;
    if (t.method == "bo") {
      // An observed point (the lowest posterior mean), told to BO as a flight.
      const auto& obs = observed.at("bo");
      EXPECT_NE(std::find(obs.begin(), obs.end(), j.dump()), obs.end()) << j.dump();
    } else {
      // bo_pso: its θ_l is an observed flight's θ_l.
      bool found = false;
      for (const auto& p : observed.at("bo_pso")) {
        const auto flown = nlohmann::json::parse(p);
        found = found || (flown["speed"] == j["speed"] && flown["margin"] == j["margin"]);
      }
      EXPECT_TRUE(found) << j.dump();
    }
  }
}

/// Rows of kind "recheck" per trial id, by (iteration = rank, index).
std::map<std::int64_t, std::map<std::pair<int, int>, EvaluationRow>> RecheckRows(const ResultStore& store) {
  std::map<std::int64_t, std::map<std::pair<int, int>, EvaluationRow>> rows;
  for (const auto& r : store.Evaluations()) {
    if (r.kind == EvalKind::kRecheck) rows[r.trial_id][{r.iteration, r.index}] = r;
  }
  return rows;
}

bool RowPasses(const EvaluationRow& r) {
  const auto t = nlohmann::json::parse(r.terms);
  return r.status == EvalStatus::kOk && t.at("completed") == 1.0 && t.at("n_c") == 0.0 && t.at("n_e") == 0.0;
}

/// mean(c) − z·sd(c) of the rows' smallest clearances (sd with n − 1).
double ClearanceBound(const std::vector<EvaluationRow>& rows, double z) {
  std::vector<double> c;
  for (const auto& r : rows) c.push_back(nlohmann::json::parse(r.terms).at("min_clearance").get<double>());
  double mean = 0.0, ss = 0.0;
  for (double v : c) mean += v / static_cast<double>(c.size());
  for (double v : c) ss += (v - mean) * (v - mean);
  return mean - z * (c.size() > 1 ? std::sqrt(ss / static_cast<double>(c.size() - 1)) : 0.0);
}

/// A toy run in a fresh folder `name` with the given `recommend:` map; its options (store path)
/// in *o.
RunSummary RunToyRecommending(const std::string& name, const Experiment& e, RunOptions* o) {
  o->store_path = test::TempDir(name) + "/r.sqlite";
  return RunExperiment(e, *o);
}

Experiment ToyRecommending(const std::string& methods, int flights, int maps,
                           const std::string& recommend) {
  return Experiment::FromString(
      test::ToyYaml(methods, "", flights, maps) + "recommend: " + recommend + "\n", "t.yaml");
}

TEST(Recommendation, ReFlightsPickTheFirstCandidateThatPassesOnSharedFreshMaps) {
  RunOptions o;
  const Experiment e = ToyRecommending("[default, random, pso, bo, bo_pso]", 8, 2,
                                       "{candidates: 4, flights: 3, clearance: 0.05, z: 1.0}");
  const RunSummary s = RunToyRecommending("recheck", e, &o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  ResultStore store(o.store_path);
  std::set<std::uint64_t> other_maps;  // tuning and held-out maps
  for (const auto& r : store.Evaluations()) {
    if (r.kind == EvalKind::kLong || r.kind == EvalKind::kValidation) other_maps.insert(r.map_seed);
  }
  const auto rechecks = RecheckRows(store);
  int passed = 0;
  for (const auto& t : s.trials) {
    if (t.method == "default") {
      EXPECT_EQ(t.recheck_flights, 0);
      EXPECT_FALSE(rechecks.count(t.trial_id));
      continue;
    }
    ASSERT_TRUE(rechecks.count(t.trial_id)) << t.method;
    const auto& rows = rechecks.at(t.trial_id);
    EXPECT_EQ(static_cast<int>(rows.size()), t.recheck_flights) << t.method;
    int last_rank = -1;
    for (const auto& [key, r] : rows) {
      // Re-flight j of every candidate and method flies map j of the repeat, with one flight seed.
      EXPECT_EQ(r.map_seed, e.RecheckMapSeed(0, key.second)) << t.method;
      EXPECT_EQ(r.flight_seed, e.RecheckFlightSeed(0, key.second)) << t.method;
      EXPECT_FALSE(other_maps.count(r.map_seed)) << "re-flight map is a tuning or held-out map";
      last_rank = std::max(last_rank, key.first);
    }
    // Every candidate before the chosen one failed a re-flight or the margin; nothing after it
    // was flown.
    for (int rank = 0; rank < last_rank || (t.recommended_rank < 0 && rank <= last_rank); ++rank) {
      std::vector<EvaluationRow> flown;
      bool failed = false;
      for (const auto& [key, r] : rows) {
        if (key.first != rank) continue;
        flown.push_back(r);
        failed = failed || !RowPasses(r);
      }
      EXPECT_TRUE(failed || (flown.size() == 3 && ClearanceBound(flown, 1.0) < 0.05))
          << t.method << " dropped candidate " << rank << " that passed";
    }
    if (t.recommended_rank >= 0) {
      ++passed;
      EXPECT_EQ(t.recommended_rank, last_rank) << t.method;
      double sum = 0.0;
      std::vector<EvaluationRow> chosen;
      for (int j = 0; j < 3; ++j) {
        const EvaluationRow& r = rows.at({last_rank, j});
        EXPECT_TRUE(RowPasses(r)) << t.method;
        nlohmann::json j_params = nlohmann::json::object();
        for (const auto& [k, v] : t.recommended) j_params[k] = v;
        EXPECT_EQ(r.params, j_params.dump()) << t.method;
        sum += r.value;
        chosen.push_back(r);
      }
      EXPECT_GE(ClearanceBound(chosen, 1.0), 0.05) << t.method;
      EXPECT_DOUBLE_EQ(t.recommended_value, sum / 3.0) << t.method;
    } else {
      EXPECT_EQ(t.recommended, e.Defaults()) << t.method;
    }
  }
  EXPECT_GT(passed, 0) << "no trial found a candidate that passes: the test checks nothing";

  // Resumed: the re-flights are replayed, nothing flies again, the same points come back.
  RunOptions again_options = o;
  again_options.resume = true;
  const RunSummary again = RunExperiment(e, again_options);
  ASSERT_EQ(again.status, RunStatus::kCompleted);
  EXPECT_EQ(again.flights, 0);
  for (std::size_t i = 0; i < s.trials.size(); ++i) {
    EXPECT_EQ(again.trials[i].recommended, s.trials[i].recommended);
    EXPECT_EQ(again.trials[i].recommended_rank, s.trials[i].recommended_rank);
  }
}

TEST(Recommendation, NoCandidatePassingGivesTheDefaultsAfterTheBackOffs) {
  // No flight keeps 50 m from every gate: each candidate flies its 4 re-flights (fewer if one
  // fails) and fails the margin. After the 3 ranked candidates, 2 back-offs towards the defaults.
  RunOptions o;
  const Experiment e = ToyRecommending("[random, bo]", 6, 0,
                                       "{candidates: 3, flights: 4, clearance: 50, z: 0, backoff: 2}");
  const RunSummary s = RunToyRecommending("recheck_none", e, &o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  ResultStore store(o.store_path);
  const auto rechecks = RecheckRows(store);
  const ParamValues d = e.Defaults();
  for (const auto& t : s.trials) {
    EXPECT_EQ(t.recommended, d) << t.method;
    EXPECT_EQ(t.recommended_rank, -1) << t.method;
    EXPECT_EQ(t.recommended_value, std::numeric_limits<double>::infinity()) << t.method;
    EXPECT_LE(t.recheck_flights, 5 * 4) << t.method;
    EXPECT_GE(t.recheck_flights, 5 * 2) << t.method;
    // Ranks 3 and 4: the first candidate moved 2/3 and 1/3 of the way from the defaults (speed
    // and margin are linear, unrounded parameters).
    std::map<int, nlohmann::json> params;
    for (const auto& [key, r] : rechecks.at(t.trial_id)) params[key.first] = nlohmann::json::parse(r.params);
    ASSERT_EQ(params.size(), 5u) << t.method;
    for (const char* name : {"speed", "margin"}) {
      const double first = params.at(0)[name].get<double>() - d.at(name);
      EXPECT_NEAR(params.at(3)[name].get<double>() - d.at(name), first * 2.0 / 3.0, 1e-9) << name;
      EXPECT_NEAR(params.at(4)[name].get<double>() - d.at(name), first / 3.0, 1e-9) << name;
    }
  }
}

TEST(Recommendation, BadRecommendKeysNameTheKey) {
  for (const std::string bad : {"{candidates: -1}", "{flights: 0}", "{clearance: -0.1}", "{z: -1}", "{backoff: -1}",
                                 "{emergency_stops: 3}", "{cands: 2}"}) {
    try {
      (void)Experiment::FromString(test::ToyYaml() + "recommend: " + bad + "\n", "t.yaml");
      FAIL() << "accepted recommend: " << bad;
    } catch (const ConfigError& ex) {
      EXPECT_NE(std::string(ex.what()).find("t.yaml"), std::string::npos) << ex.what();
      EXPECT_NE(std::string(ex.what()).find("recommend"), std::string::npos) << ex.what();
    }
  }
}

TEST(DiscountCount, NdAdvancesOncePerChangeOfTheFlyingThetaSAndIsStored) {
  const std::string dir = test::TempDir("n_d");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  const Experiment e = Experiment::FromString(test::ToyYaml("[bo_pso]", "", 9, 0), "t.yaml");
  const RunSummary s = RunExperiment(e, o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  const auto rows = LongRows(o.store_path).at({"bo_pso", 0});
  ASSERT_EQ(rows.size(), 9u);
  int previous = 0;
  std::string previous_short;
  for (const auto& r : rows) {
    const auto terms = nlohmann::json::parse(r.terms);
    ASSERT_TRUE(terms.contains("n_d")) << r.terms;
    const int n_d = terms["n_d"].get<int>();
    const auto params = nlohmann::json::parse(r.params);
    const std::string theta_s = params["gain"].dump() + "," + params["max_iter"].dump();
    // n_d grows by one exactly when the θ_s flown changes from one round to the next.
    if (!previous_short.empty() && r.index == 0) {
      EXPECT_EQ(n_d - previous, theta_s != previous_short ? 1 : 0) << "iteration " << r.iteration;
    } else if (r.index > 0) {
      EXPECT_EQ(n_d, previous);  // flights of one round share θ_s and n_d
    }
    previous = n_d;
    previous_short = theta_s;
  }
  EXPECT_EQ(previous, s.trials[0].context_changes);
  EXPECT_GT(previous, 0);
}

}  // namespace
}  // namespace quadtune::engine
