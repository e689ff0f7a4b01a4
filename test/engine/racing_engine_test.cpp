// Racing inside the tuner (experiment `race:`): every flight counts against the budget,
// incumbent and challenger fly the same race maps, the trial hands back its incumbent, and a
// run cut inside a race resumes to the same store.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "../config_error_util.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "test_util.hpp"

namespace quadtune::engine {
namespace {

constexpr int kFlights = 30;

Experiment RacingToy(const std::string& methods = "[default, random, pso, bo, bo_pso]",
                     const std::string& race = "{enabled: true, first_maps: 2, max_maps: 8}",
                     int flights = kFlights) {
  return Experiment::FromString(
      test::ToyYaml(methods, "", flights, 0) + "race: " + race + "\n", "toy.yaml");
}

struct Rows {
  std::vector<EvaluationRow> tuning, race, incumbent;
};

std::map<std::int64_t, Rows> RowsByTrial(const std::string& store_path) {
  std::map<std::int64_t, Rows> out;
  ResultStore store(store_path);
  for (const auto& r : store.Evaluations()) {
    auto& t = out[r.trial_id];
    if (r.kind == EvalKind::kLong) t.tuning.push_back(r);
    if (r.kind == EvalKind::kRace) t.race.push_back(r);
    if (r.kind == EvalKind::kIncumbent) t.incumbent.push_back(r);
  }
  return out;
}

double TermOf(const EvaluationRow& r, const char* name) {
  return nlohmann::json::parse(r.terms).at(name).get<double>();
}

RunSummary RunRacing(const std::string& name, const Experiment& e, RunOptions* o) {
  o->store_path = test::TempDir(name) + "/r.sqlite";
  return RunExperiment(e, *o);
}

/// Runs RacingToy(methods, race) to completion into a fresh store; its rows by trial.
std::map<std::int64_t, Rows> RacedRows(const std::string& name, const std::string& methods,
                                       const std::string& race, int flights = kFlights) {
  RunOptions o;
  const RunSummary s = RunRacing(name, RacingToy(methods, race, flights), &o);
  EXPECT_EQ(s.status, RunStatus::kCompleted);
  return RowsByTrial(o.store_path);
}

TEST(Racing, EveryFlightCountsAgainstTheBudget) {
  RunOptions o;
  const RunSummary s = RunRacing("race_budget", RacingToy(), &o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  const auto rows = RowsByTrial(o.store_path);
  int races = 0;
  for (const auto& t : s.trials) {
    const Rows& r = rows.at(t.trial_id);
    if (t.method == "default") {
      EXPECT_TRUE(r.race.empty());
      EXPECT_EQ(t.races, 0);
      continue;
    }
    EXPECT_EQ(static_cast<int>(r.tuning.size() + r.race.size()), kFlights) << t.method;
    EXPECT_EQ(t.flights, kFlights) << t.method;
    EXPECT_EQ(t.race_flights, static_cast<int>(r.race.size())) << t.method;
    EXPECT_EQ(t.races, static_cast<int>(r.incumbent.size())) << t.method;
    // flight_no numbers every flight of the trial once, 1 … budget.
    std::set<int> numbers;
    for (const auto* kind : {&r.tuning, &r.race}) {
      for (const auto& row : *kind) numbers.insert(static_cast<int>(TermOf(row, "flight_no")));
    }
    EXPECT_EQ(static_cast<int>(numbers.size()), kFlights) << t.method;
    EXPECT_EQ(*numbers.begin(), 1);
    EXPECT_EQ(*numbers.rbegin(), kFlights);
    races += t.races;
  }
  EXPECT_GT(races, 4) << "the toy runs should race";
}

TEST(Racing, ReserveRunsOnlyWholeRacesAndEndsTheTrialRacing) {
  RunOptions o;
  const RunSummary s = RunRacing(
      "race_reserve",
      RacingToy("[random, bo_pso]", "{enabled: true, first_maps: 2, max_maps: 8, reserve: true}"),
      &o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  const auto rows = RowsByTrial(o.store_path);
  int cut_without = 0;
  {
    RunOptions plain;
    const RunSummary p = RunRacing("race_no_reserve", RacingToy("[random, bo_pso]"), &plain);
    for (const auto& [id, r] : RowsByTrial(plain.store_path)) {
      for (const auto& row : r.incumbent) cut_without += nlohmann::json::parse(row.terms).contains("stopped");
    }
  }
  for (const auto& t : s.trials) {
    const Rows& r = rows.at(t.trial_id);
    EXPECT_LE(t.flights, kFlights) << t.method;
    EXPECT_EQ(static_cast<int>(r.tuning.size() + r.race.size()), t.flights) << t.method;
    ASSERT_FALSE(r.incumbent.empty()) << t.method;
    for (const auto& row : r.incumbent) {
      EXPECT_FALSE(nlohmann::json::parse(row.terms).contains("stopped"))
          << t.method << " race " << row.iteration << " was cut by the budget";
    }
    // The trial's last flights are a race's: no tuning flight after the last race began.
    int last_tuning = 0;
    for (const auto& row : r.tuning) last_tuning = std::max(last_tuning, static_cast<int>(TermOf(row, "flight_no")));
    int last_race_start = 0;
    for (const auto& row : r.race) {
      if (row.iteration == r.incumbent.back().iteration) {
        const int no = static_cast<int>(TermOf(row, "flight_no"));
        last_race_start = last_race_start == 0 ? no : std::min(last_race_start, no);
      }
    }
    EXPECT_LT(last_tuning, last_race_start) << t.method;
    // A whole race (at most 8 maps for each side) no longer fits the flights left.
    EXPECT_GT(t.flights + 2 * 8, kFlights) << t.method;
  }
  EXPECT_GT(cut_without, 0) << "without reserve some race of these trials is cut by the budget";
}

// race.incumbent_short: bo_pso also races a θ_l of BO's with the incumbent's θ_s (challengers
// whose θ_s is the incumbent's and whose θ_l is not); without it every challenger carries PSO's
// best θ_s.
TEST(Racing, IncumbentShortRacesBosThetaLWithTheIncumbentsThetaS) {
  const auto count = [](const std::string& name, const std::string& race) {
    int with_incumbents = 0;
    for (const auto& [id, r] : RacedRows(name, "[bo_pso]", race)) {
      nlohmann::json incumbent = nlohmann::json::parse(r.race.front().params);  // the defaults
      for (const auto& outcome : r.incumbent) {
        for (const auto& row : r.race) {
          if (row.iteration != outcome.iteration || TermOf(row, "challenger") != 1.0) continue;
          const auto c = nlohmann::json::parse(row.params);
          const bool same_short = c["gain"] == incumbent["gain"] && c["max_iter"] == incumbent["max_iter"];
          const bool same_long = c["speed"] == incumbent["speed"] && c["margin"] == incumbent["margin"];
          with_incumbents += same_short && !same_long;
          break;
        }
        incumbent = nlohmann::json::parse(outcome.params);
      }
    }
    return with_incumbents;
  };
  const std::string race = "{enabled: true, first_maps: 2, max_maps: 8, challenger: two_part, share: 0.9";
  EXPECT_EQ(count("race_short_off", race + "}"), 0);
  EXPECT_GT(count("race_short_on", race + ", incumbent_short: true}"), 0);
}

TEST(Racing, IncumbentAndChallengerFlyTheSameRaceMaps) {
  RunOptions o;
  const Experiment e = RacingToy();
  const RunSummary s = RunRacing("race_maps", e, &o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  const auto rows = RowsByTrial(o.store_path);
  std::set<std::uint64_t> other_maps;
  for (const auto& [id, r] : rows) {
    for (const auto& row : r.tuning) other_maps.insert(row.map_seed);
  }
  for (const auto& t : s.trials) {
    if (t.method == "default") continue;
    const Rows& r = rows.at(t.trial_id);
    // Which race maps each parameter set has flown so far (params JSON → maps).
    std::map<std::string, std::set<int>> flown;
    std::string incumbent = nlohmann::json(e.Defaults()).dump();
    for (const auto& outcome : r.incumbent) {
      std::set<int> challenger_maps;
      std::string challenger;
      for (const auto& row : r.race) {
        if (row.iteration != outcome.iteration) continue;
        const int j = static_cast<int>(TermOf(row, "race_map"));
        EXPECT_EQ(row.map_seed, e.RaceMapSeed(0, j));
        EXPECT_EQ(row.flight_seed, e.RaceFlightSeed(0, j));
        EXPECT_FALSE(other_maps.count(row.map_seed)) << "a race map is a tuning map";
        flown[row.params].insert(j);
        if (TermOf(row, "challenger") == 1.0) {
          challenger_maps.insert(j);
          challenger = row.params;
        } else {
          EXPECT_EQ(row.params, incumbent) << t.method << " race " << outcome.iteration;
        }
      }
      ASSERT_FALSE(challenger_maps.empty()) << t.method;
      // The challenger flew maps 0 … n−1, and the incumbent has flown every one of them.
      EXPECT_EQ(*challenger_maps.rbegin(), static_cast<int>(challenger_maps.size()) - 1);
      for (int j : challenger_maps) EXPECT_TRUE(flown[incumbent].count(j)) << t.method;
      if (TermOf(outcome, "accepted") == 1.0) incumbent = challenger;
      EXPECT_EQ(outcome.params, incumbent);
    }
    // The trial hands back its last incumbent.
    EXPECT_EQ(nlohmann::json(t.recommended).dump(), incumbent) << t.method;
    EXPECT_EQ(t.recommended_rank, t.incumbent_changes > 0 ? 0 : -1);
  }
}

TEST(Racing, ToyTrialsHandBackAWinnerBetterThanTheDefaultsOnHeldOutMaps) {
  RunOptions o;
  const Experiment e = Experiment::FromString(
      test::ToyYaml("[default, bo, bo_pso]", "", 60, 12) +
          "race: {enabled: true, first_maps: 4, max_maps: 8}\n",
      "toy.yaml");
  const RunSummary s = RunRacing("race_heldout", e, &o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  ASSERT_EQ(s.validation.size(), s.trials.size() + 1);
  const double defaults = s.validation[0].mean_value;
  int changed = 0;
  for (std::size_t i = 1; i < s.validation.size(); ++i) {
    // A challenger replaces the defaults only on paired evidence, so no recommended point may be
    // worse than the defaults on maps no trial flew.
    EXPECT_LE(s.validation[i].mean_value, defaults * 1.02) << s.validation[i].method;
  }
  for (const auto& t : s.trials) changed += t.incumbent_changes > 0 ? 1 : 0;
  EXPECT_GE(changed, 1);
}

class RacingCancelResume : public ::testing::TestWithParam<int> {};

/// Cut after N progress reports (rounds and race stages), resumed, equals an uncut run.
TEST_P(RacingCancelResume, ResumedRunEqualsUninterruptedRun) {
  const int cut_after = GetParam();
  const auto r = test::CutThenResume(RacingToy("[bo_pso, random]"),
                                     test::TempDir("race_resume" + std::to_string(cut_after)),
                                     cut_after);
  ASSERT_EQ(r.cut.status, RunStatus::kCancelled);
  ASSERT_EQ(r.resumed.status, RunStatus::kCompleted);
  EXPECT_EQ(test::Deterministic(r.part), test::Deterministic(r.full));
  EXPECT_LT(r.partial.size(), test::Deterministic(r.full).size());
}

/// Whether some race in `rows` (test::Deterministic strings: method|kind|iteration|…) has
/// flights but no outcome: the cut fell inside it.
bool CutInsideARace(const std::vector<std::string>& rows) {
  std::set<std::string> started, ended;
  for (const auto& row : rows) {
    std::vector<std::string> f;
    std::size_t at = 0;
    for (int i = 0; i < 3; ++i) {
      const std::size_t bar = row.find('|', at);
      f.push_back(row.substr(at, bar - at));
      at = bar + 1;
    }
    if (f[1] == "race") started.insert(f[0] + "/" + f[2]);
    if (f[1] == "incumbent") ended.insert(f[0] + "/" + f[2]);
  }
  return started.size() > ended.size();
}

TEST(Racing, SomeCutFallsInsideARace) {
  // The cut points of RacingCancelResume include one inside a race (a stage done, the next not).
  bool inside = false;
  for (int cut : {4, 6, 9}) {
    const auto r = test::CutThenResume(RacingToy("[bo_pso, random]"),
                                       test::TempDir("race_cut" + std::to_string(cut)), cut);
    inside = inside || CutInsideARace(r.partial);
  }
  EXPECT_TRUE(inside);
}

INSTANTIATE_TEST_SUITE_P(Tuner, RacingCancelResume, ::testing::Values(4, 6, 9));

TEST(Racing, TwoPartChallengersAreScoredStoredAndResumedIdentically) {
  const Experiment e =
      RacingToy("[bo_pso, random]", "{enabled: true, first_maps: 2, max_maps: 8, challenger: two_part}");
  const auto r = test::CutThenResume(e, test::TempDir("race_two_part"), 6);
  ASSERT_EQ(r.resumed.status, RunStatus::kCompleted);
  EXPECT_EQ(test::Deterministic(r.part), test::Deterministic(r.full));
  RunOptions o;
  (void)RunRacing("race_two_part_rows", e, &o);
  int scored = 0;
  for (const auto& [id, rows] : RowsByTrial(o.store_path)) {
    for (const auto& row : rows.incumbent) {
      const double p = TermOf(row, "challenger_p_fail");
      EXPECT_GE(p, 0.0);
      EXPECT_LE(p, 1.0);
      EXPECT_GE(TermOf(row, "challenger_score"), 0.0);
      ++scored;
    }
  }
  EXPECT_GE(scored, 2);
}

// race.propose: the two_part model races points of its own, which no tuning flight flew, within
// propose_radius of the incumbent; without it every challenger is a flown point; a run cut
// inside such a race resumes to the same store.
TEST(Racing, ProposedChallengersAreNewPointsNearTheIncumbentAndResumeIdentically) {
  const auto count = [](const std::string& name, const std::string& race) {
    int proposed = 0;
    for (const auto& [id, r] : RacedRows(name, "[bo, random]", race)) {
      std::set<nlohmann::json> flown;
      for (const auto& row : r.tuning) flown.insert(nlohmann::json::parse(row.params));
      for (const auto& row : r.race) {
        if (TermOf(row, "challenger") != 1.0) continue;
        proposed += flown.count(nlohmann::json::parse(row.params)) == 0 ? 1 : 0;
      }
    }
    return proposed;
  };
  const std::string race = "{enabled: true, first_maps: 2, max_maps: 8, challenger: two_part, share: 0.9";
  EXPECT_EQ(count("race_propose_off", race + "}"), 0);
  EXPECT_GT(count("race_propose_on", race + ", propose: true}"), 0);
  const Experiment e = RacingToy("[bo, random]", race + ", propose: true, propose_radius: 0.3}");
  const auto r = test::CutThenResume(e, test::TempDir("race_propose_resume"), 6);
  ASSERT_EQ(r.resumed.status, RunStatus::kCompleted);
  EXPECT_EQ(test::Deterministic(r.part), test::Deterministic(r.full));
}

// race.failure_margin: a race won on the maps is checked against the failure model; each checked
// race stores both probabilities, and a winner kept them within the margin, a loser did not.
TEST(Racing, FailureMarginChecksEveryWinnerAgainstTheModel) {
  const auto checked = [](const std::string& name, const std::string& race) {
    int n = 0;
    for (const auto& [id, r] : RacedRows(name, "[bo, random, bo_pso]", race)) {
      for (const auto& row : r.incumbent) {
        const auto terms = nlohmann::json::parse(row.terms);
        if (!terms.contains("gate_p_fail")) continue;
        ++n;
        const double margin = terms["gate_p_fail"].get<double>() - terms["gate_p_fail_incumbent"].get<double>();
        if (terms["accepted"].get<double>() == 1.0) {
          EXPECT_LE(margin, 0.01);
        } else {
          EXPECT_GT(margin, 0.01);
        }
      }
    }
    return n;
  };
  const std::string race = "{enabled: true, first_maps: 2, max_maps: 8, challenger: two_part, share: 0.9";
  EXPECT_EQ(checked("race_margin_off", race + "}"), 0);
  EXPECT_GT(checked("race_margin_on", race + ", failure_margin: 0.01}"), 0);
}

/// A point's place in e's unit cube.
Eigen::VectorXd UnitOf(const Experiment& e, const nlohmann::json& p) {
  const auto names = e.space.Names();
  Eigen::VectorXd x(static_cast<Eigen::Index>(e.space.Dim()));
  for (std::size_t i = 0; i < names.size(); ++i) x[static_cast<Eigen::Index>(i)] = p[names[i]].get<double>();
  return e.space.ToUnit(x);
}

/// The point at unit-cube place u (snapped) over b's other parameters.
nlohmann::json AtUnit(const Experiment& e, const Eigen::VectorXd& u, const nlohmann::json& b) {
  const auto names = e.space.Names();
  const Eigen::VectorXd x = e.space.FromUnit(e.space.SnapUnit(u));
  nlohmann::json out = b;
  for (std::size_t i = 0; i < names.size(); ++i) out[names[i]] = x[static_cast<Eigen::Index>(i)];
  return out;
}

/// The point halfway between a and b in e's unit cube (snapped), over b's other parameters: the
/// tuner's race.backoff point.
nlohmann::json Halfway(const Experiment& e, const nlohmann::json& a, const nlohmann::json& b) {
  return AtUnit(e, 0.5 * (UnitOf(e, a) + UnitOf(e, b)), b);
}

// race.backoff: a challenger turned away after failing a race map while faster than the
// incumbent on the maps neither failed is followed by the halfway point between it and the
// incumbent, at most `backoff` times in a row; without it no race is a back-off; a run cut inside
// such a race resumes to the same store.
TEST(Racing, BackoffRacesTheHalfwayPointAfterAFasterChallengerFailed) {
  const std::string race = "{enabled: true, first_maps: 2, max_maps: 8, share: 0.9";
  const Experiment e = RacingToy("[bo, random]", race + ", backoff: 2}");
  const auto backoffs = [&](const std::string& name, const std::string& options) {
    int n = 0;
    for (const auto& [id, r] : RacedRows(name, "[bo, random]", options)) {
      // Each parameter set's first flight of each race map: failed, f_l.
      std::map<std::pair<std::string, int>, std::pair<bool, double>> flown;
      for (const auto& row : r.race) {
        const bool failed = TermOf(row, "completed") != 1.0 || TermOf(row, "n_c") != 0.0;
        flown.emplace(std::pair{nlohmann::json::parse(row.params).dump(),
                                static_cast<int>(TermOf(row, "race_map"))},
                      std::pair{failed, row.value});
      }
      nlohmann::json incumbent = nlohmann::json::parse(r.race.front().params);  // the defaults
      nlohmann::json last_challenger;
      bool last_failed_faster = false;
      int last_depth = 0;
      for (const auto& outcome : r.incumbent) {
        nlohmann::json challenger;
        std::set<int> maps;
        for (const auto& row : r.race) {
          if (row.iteration != outcome.iteration || TermOf(row, "challenger") != 1.0) continue;
          challenger = nlohmann::json::parse(row.params);
          maps.insert(static_cast<int>(TermOf(row, "race_map")));
        }
        const auto terms = nlohmann::json::parse(outcome.terms);
        const int depth = terms.contains("backoff") ? static_cast<int>(terms["backoff"].get<double>()) : 0;
        if (depth > 0) {
          ++n;
          EXPECT_TRUE(last_failed_faster) << "race " << outcome.iteration;
          EXPECT_EQ(depth, last_depth + 1);
          EXPECT_LE(depth, 2);
          const nlohmann::json expected = Halfway(e, incumbent, last_challenger);
          for (const auto& name : e.space.Names()) {
            EXPECT_NEAR(challenger[name].get<double>(), expected[name].get<double>(), 1e-9) << name;
          }
        }
        // Did this challenger fail a map and lead on the maps neither side failed?
        int failures = 0, clean = 0;
        double difference = 0.0;
        for (int map : maps) {
          const auto c = flown.at({challenger.dump(), map});
          const auto i = flown.at({incumbent.dump(), map});
          failures += c.first ? 1 : 0;
          if (c.first || i.first) continue;
          ++clean;
          difference += c.second - i.second;
        }
        const bool accepted = TermOf(outcome, "accepted") == 1.0;
        last_failed_faster = !accepted && failures > 0 && clean > 0 && difference < 0.0;
        last_depth = depth;
        last_challenger = challenger;
        if (accepted) incumbent = challenger;
      }
    }
    return n;
  };
  EXPECT_EQ(backoffs("race_backoff_off", race + "}"), 0);
  EXPECT_GT(backoffs("race_backoff_on", race + ", backoff: 2}"), 0);
  const auto r = test::CutThenResume(e, test::TempDir("race_backoff_resume"), 6);
  ASSERT_EQ(r.resumed.status, RunStatus::kCompleted);
  EXPECT_EQ(test::Deterministic(r.part), test::Deterministic(r.full));
}

// race.bisect: a back-off point that wins is followed at once by the point halfway between it
// and the challenger whose failure began the back-off, one halving deeper.
TEST(Racing, BisectRacesTowardsTheFailedChallengerAfterAHalfwayWin) {
  const std::string race =
      "{enabled: true, first_maps: 2, max_maps: 8, share: 0.9, backoff: 3, bisect: true}";
  const std::string methods = "[random, pso, bo, bo_pso]";
  const Experiment e = RacingToy(methods, race, 80);
  int bisected = 0;
  for (const auto& [id, r] : RacedRows("race_bisect", methods, race, 80)) {
    std::vector<nlohmann::json> challengers;
    std::vector<int> depths;
    std::vector<bool> accepted;
    for (const auto& outcome : r.incumbent) {
      for (const auto& row : r.race) {
        if (row.iteration == outcome.iteration && TermOf(row, "challenger") == 1.0) {
          challengers.push_back(nlohmann::json::parse(row.params));
          break;
        }
      }
      const auto terms = nlohmann::json::parse(outcome.terms);
      depths.push_back(terms.contains("backoff") ? static_cast<int>(terms["backoff"].get<double>()) : 0);
      accepted.push_back(TermOf(outcome, "accepted") == 1.0);
    }
    ASSERT_EQ(challengers.size(), depths.size());
    nlohmann::json failed;
    for (std::size_t k = 1; k < depths.size(); ++k) {
      if (depths[k] > 0 && !accepted[k - 1]) failed = challengers[k - 1];
      if (accepted[k - 1] && depths[k - 1] >= 1 && depths[k - 1] < 3) {
        EXPECT_EQ(depths[k], depths[k - 1] + 1) << "race " << k;
        const nlohmann::json expected = Halfway(e, challengers[k - 1], failed);
        for (const auto& name : e.space.Names()) {
          EXPECT_NEAR(challengers[k][name].get<double>(), expected[name].get<double>(), 1e-9) << name;
        }
        ++bisected;
      }
    }
  }
  EXPECT_GT(bisected, 0);
}

/// The point one more step on from a to b in e's unit cube (2·u_b − u_a, clamped, snapped), over
/// b's other parameters: the tuner's race.extrapolate point.
nlohmann::json Beyond(const Experiment& e, const nlohmann::json& a, const nlohmann::json& b) {
  return AtUnit(e, (2.0 * UnitOf(e, b) - UnitOf(e, a)).cwiseMax(0.0).cwiseMin(1.0), b);
}

// race.extrapolate: a challenger that wins (not a back-off point) is followed at once by the
// point one more such step on, counted in a row up to the limit; without it no race is one; a
// run cut inside such a race resumes to the same store.
TEST(Racing, ExtrapolateRacesOneMoreStepAfterAWin) {
  const std::string race = "{enabled: true, first_maps: 2, max_maps: 8, share: 0.9, backoff: 1";
  const std::string methods = "[random, pso, bo, bo_pso]";
  const Experiment e = RacingToy(methods, race + ", extrapolate: 2}", 80);
  const auto steps = [&](const std::string& name, const std::string& options, int limit) {
    int n = 0;
    for (const auto& [id, r] : RacedRows(name, methods, options, 80)) {
      nlohmann::json incumbent = nlohmann::json::parse(r.race.front().params);  // the defaults
      std::vector<Eigen::VectorXd> raced{UnitOf(e, incumbent)};
      nlohmann::json before;  // the incumbent before the last race, when that race was won
      int last_step = 0, last_depth = 0;
      bool last_accepted = false;
      for (const auto& outcome : r.incumbent) {
        nlohmann::json challenger;
        for (const auto& row : r.race) {
          if (row.iteration == outcome.iteration && TermOf(row, "challenger") == 1.0) {
            challenger = nlohmann::json::parse(row.params);
            break;
          }
        }
        const auto terms = nlohmann::json::parse(outcome.terms);
        const auto term = [&](const char* key) {
          return terms.contains(key) ? static_cast<int>(terms[key].get<double>()) : 0;
        };
        const int step = term("extrapolation");
        // A won race that was no back-off is followed by a step while fewer than `limit` in a
        // row, unless that point (nearly) raced already.
        const bool due = last_accepted && last_depth == 0 && last_step < limit;
        if (due) {
          const nlohmann::json expected = Beyond(e, before, incumbent);
          const bool skipped = std::any_of(raced.begin(), raced.end(), [&](const Eigen::VectorXd& v) {
            return (v - UnitOf(e, expected)).cwiseAbs().maxCoeff() < 0.02;
          });
          if (!skipped) {
            ++n;
            EXPECT_EQ(step, last_step + 1) << "race " << outcome.iteration;
            for (const auto& key : e.space.Names()) {
              EXPECT_NEAR(challenger[key].get<double>(), expected[key].get<double>(), 1e-9) << key;
            }
          }
        } else {
          EXPECT_EQ(step, 0) << "race " << outcome.iteration;
        }
        raced.push_back(UnitOf(e, challenger));
        last_accepted = TermOf(outcome, "accepted") == 1.0;
        last_depth = term("backoff");
        last_step = step;
        if (last_accepted) {
          before = incumbent;
          incumbent = challenger;
        }
      }
    }
    return n;
  };
  EXPECT_EQ(steps("race_extrapolate_off", race + "}", 0), 0);
  EXPECT_GT(steps("race_extrapolate_on", race + ", extrapolate: 2}", 2), 0);
  const auto r = test::CutThenResume(e, test::TempDir("race_extrapolate_resume"), 6);
  ASSERT_EQ(r.resumed.status, RunStatus::kCompleted);
  EXPECT_EQ(test::Deterministic(r.part), test::Deterministic(r.full));
}

TEST(Racing, ExperimentFileRulesAreChecked) {
  EXPECT_TRUE(quadtune::test::ThrowsConfigError(
      [] { (void)RacingToy("[bo]", "{enabled: true, first_maps: 8, max_maps: 4}"); },
      "race.max_maps", {"first_maps", "8"}));
  EXPECT_TRUE(quadtune::test::ThrowsConfigError(
      [] {
        (void)Experiment::FromString(test::ToyYaml("[bo]", "", 6, 0) +
                                         "recommend: {candidates: 3}\nrace: {enabled: true}\n",
                                     "toy.yaml");
      },
      "race.enabled", {"recommend.candidates"}));
  EXPECT_TRUE(quadtune::test::ThrowsConfigError([] { (void)RacingToy("[bo]", "{alpha: 0.7}"); },
                                      "race.alpha", {"0.7"}));
  EXPECT_TRUE(quadtune::test::ThrowsConfigError(
      [] { (void)RacingToy("[bo]", "{enabled: true, propose: true}"); }, "race.propose",
      {"two_part"}));
}

}  // namespace
}  // namespace quadtune::engine
