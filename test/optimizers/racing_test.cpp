// Racing a challenger against an incumbent: the signed-rank test, the race rule, and the rates
// at which races on a synthetic noisy objective keep or replace the incumbent.
#include "quadtune/optimizers/racing.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "quadtune/common/random.hpp"

namespace quadtune::optimizers {
namespace {

TEST(SignedRank, ExactValuesMatchCountedSignPatterns) {
  // Five negative differences: only the all-negative pattern is as extreme, 1/32.
  EXPECT_DOUBLE_EQ(SignedRankPValueLower({-1, -2, -3, -4, -5}), 1.0 / 32.0);
  EXPECT_DOUBLE_EQ(SignedRankPValueLower({-1, -2, -3, -4}), 1.0 / 16.0);
  // Ranks 1, 2, 3 with rank 3 positive: W+ = 3; sign patterns with W+ <= 3 are {}, {1}, {2},
  // {3}, {1, 2}: 5 of 8.
  EXPECT_DOUBLE_EQ(SignedRankPValueLower({-1, -2, 3}), 5.0 / 8.0);
  // Zeros are dropped.
  EXPECT_DOUBLE_EQ(SignedRankPValueLower({0.0, -1, -2}), 1.0 / 4.0);
  // Tied magnitudes share rank 2: W+ = 2 of 6; patterns with W+ <= 2: {} and three singletons.
  EXPECT_DOUBLE_EQ(SignedRankPValueLower({-1, -1, 1}), 4.0 / 8.0);
  EXPECT_DOUBLE_EQ(SignedRankPValueLower({}), 1.0);
  EXPECT_DOUBLE_EQ(SignedRankPValueLower({0.0, 0.0}), 1.0);
}

TEST(SignedRank, MatchesScipyWilcoxonLess) {
  // scipy.stats.wilcoxon(x, alternative='less').pvalue (exact) for these samples.
  EXPECT_NEAR(SignedRankPValueLower({-3.1, -1.2, 0.5, -2.2, -0.7, -4.0, 1.1, -2.5}), 0.02734375,
              1e-12);
  EXPECT_NEAR(SignedRankPValueLower(
                  {-3.1, -1.2, 0.5, -2.2, -0.7, -4.0, 1.1, -2.5, 2.0, -0.3, 0.9, -1.7}),
              0.064697265625, 1e-12);
}

TEST(SignedRank, NormalApproximationAgreesWithExactAtTheSwitch) {
  // 60 differences are counted exactly, 61 approximated; adding one tiny positive difference
  // (rank 1) barely moves the p-value, so the two must nearly agree.
  std::vector<double> d;
  for (int i = 0; i < 60; ++i) d.push_back((i % 3 == 0 ? 1.0 : -1.0) * (1.0 + i));
  const double exact = SignedRankPValueLower(d);
  d.push_back(1e-6);
  const double approx = SignedRankPValueLower(d);
  EXPECT_GT(exact, 1e-4);
  EXPECT_NEAR(approx, exact, 0.2 * exact);
}

std::vector<RaceSample> Samples(const std::vector<double>& values,
                                const std::vector<bool>& failed = {}) {
  std::vector<RaceSample> out;
  for (std::size_t i = 0; i < values.size(); ++i) {
    out.push_back({values[i], i < failed.size() && failed[i]});
  }
  return out;
}

TEST(JudgeRace, AppliesEachRule) {
  RaceOptions o;
  o.first_maps = 4;
  o.max_maps = 8;
  o.alpha = 0.05;
  const auto inc = Samples({30, 31, 29, 30, 32, 30, 28, 31});
  // Worse on average: rejected at the first look.
  auto d = JudgeRace(inc, Samples({31, 32, 28, 31}), 4, o);
  EXPECT_EQ(d.verdict, RaceVerdict::kReject);
  EXPECT_GT(d.mean_difference, 0.0);
  // Better on all four: before max_maps the race doubles to 8 maps.
  d = JudgeRace(inc, Samples({28, 29, 27, 28}), 4, o);
  EXPECT_EQ(d.verdict, RaceVerdict::kContinue);
  EXPECT_EQ(d.maps, 8);
  EXPECT_DOUBLE_EQ(d.p_value, 1.0 / 16.0);
  // Better on all eight: p = 1/256, accepted.
  d = JudgeRace(inc, Samples({28, 29, 27, 28, 30, 28, 26, 29}), 8, o);
  EXPECT_EQ(d.verdict, RaceVerdict::kAccept);
  // Ahead on average but not significant at the last stage: rejected.
  d = JudgeRace(inc, Samples({28, 33, 27, 32, 30, 31, 26, 29}), 8, o);
  EXPECT_LT(d.mean_difference, 0.0);
  EXPECT_EQ(d.verdict, RaceVerdict::kReject);
  // Faster, but fails a map the incumbent finished: rejected whatever the p-value.
  d = JudgeRace(inc, Samples({20, 21, 19, 20, 22, 20, 18, 21}, {false, true, false, false}), 8, o);
  EXPECT_EQ(d.verdict, RaceVerdict::kReject);
  EXPECT_EQ(d.challenger_only_failures, 1);
  // With one failure allowed, both in all and beyond the incumbent's, the same race is won, and
  // a second failure loses it again.
  o.failures = 1;
  o.failure_excess = 1;
  EXPECT_EQ(JudgeRace(inc, Samples({20, 21, 19, 20, 22, 20, 18, 21}, {false, true}), 8, o).verdict,
            RaceVerdict::kAccept);
  EXPECT_EQ(JudgeRace(inc, Samples({20, 21, 19, 20, 22, 20, 18, 21}, {false, true, true}), 8, o)
                .verdict,
            RaceVerdict::kReject);
  o.failure_excess = 2;
  EXPECT_EQ(JudgeRace(inc, Samples({20, 21, 19, 20, 22, 20, 18, 21}, {false, true, true}), 8, o)
                .verdict,
            RaceVerdict::kReject);  // `failures` still bounds its own
  o.failures = 0;
  o.failure_excess = 0;
  // A challenger failing a map is turned away even when the incumbent failed another one:
  // its own failures are bounded by `failures` (0).
  auto inc_other = inc;
  inc_other[5] = {1000.0, true};
  d = JudgeRace(inc_other, Samples({20, 21, 19, 20, 22, 20, 18, 21}, {false, true}), 8, o);
  EXPECT_EQ(d.challenger_only_failures, 1);
  EXPECT_EQ(d.incumbent_only_failures, 1);
  EXPECT_EQ(d.verdict, RaceVerdict::kReject);
  o.failures = 1;
  EXPECT_EQ(JudgeRace(inc_other, Samples({20, 21, 19, 20, 22, 20, 18, 21}, {false, true}), 8, o)
                .verdict,
            RaceVerdict::kAccept);
  o.failures = 0;
  // The incumbent's own failure (value 1000) does not swamp the rank test.
  auto inc_fail = inc;
  inc_fail[2] = {1000.0, true};
  d = JudgeRace(inc_fail, Samples({28, 29, 27, 28, 30, 28, 26, 29}), 8, o);
  EXPECT_EQ(d.verdict, RaceVerdict::kAccept);
  EXPECT_EQ(d.incumbent_only_failures, 1);
}

/// A synthetic flight: arm mean + the map's difficulty (shared by every arm, as common random
/// numbers share a map) + the arm's own noise; with probability `fail` the flight fails and
/// scores 1000, like an unfinished flight.
struct Arm {
  double mean = 30.0;
  double fail = 0.02;
};

RaceSample Fly(const Arm& arm, int arm_index, int map, std::uint64_t seed) {
  Rng map_rng(DeriveSeed(seed, {0x3a9, static_cast<std::uint64_t>(map)}));
  const double difficulty = 4.0 * StandardNormal(map_rng);
  Rng rng(DeriveSeed(seed, {static_cast<std::uint64_t>(arm_index), static_cast<std::uint64_t>(map)}));
  const double noise = 2.0 * StandardNormal(rng);
  if (Uniform01(rng) < arm.fail) return {1000.0, true};
  return {arm.mean + difficulty + noise, false};
}

/// Races the arms 1, 2, … in turn against the incumbent (arm 0 first); returns the final
/// incumbent's index.
int RaceInTurn(const std::vector<Arm>& arms, const RaceOptions& o, std::uint64_t seed,
               int* flights) {
  int incumbent = 0;
  std::vector<RaceSample> inc_samples;
  for (int c = 1; c < static_cast<int>(arms.size()); ++c) {
    std::vector<RaceSample> ch;
    auto extend = [&](int n) {
      while (static_cast<int>(inc_samples.size()) < n) {
        inc_samples.push_back(Fly(arms[static_cast<std::size_t>(incumbent)], incumbent,
                                  static_cast<int>(inc_samples.size()), seed));
        ++*flights;
      }
      while (static_cast<int>(ch.size()) < n) {
        ch.push_back(Fly(arms[static_cast<std::size_t>(c)], c, static_cast<int>(ch.size()), seed));
        ++*flights;
      }
      return true;
    };
    const RaceDecision d = RunRace(o, &inc_samples, &ch, extend);
    if (d.verdict == RaceVerdict::kAccept) {
      incumbent = c;
      inc_samples = ch;
    }
  }
  return incumbent;
}

RaceOptions Standard() {
  RaceOptions o;
  o.enabled = true;
  o.first_maps = 4;
  o.max_maps = 12;
  o.alpha = 0.05;
  return o;
}

TEST(RaceRates, AChallengerTenPercentBetterWinsMostRaces) {
  int wins = 0;
  int flights = 0;
  constexpr int kRaces = 400;
  for (int s = 0; s < kRaces; ++s) {
    wins += RaceInTurn({{30.0}, {27.0}}, Standard(), 1000 + s, &flights) == 1 ? 1 : 0;
  }
  // Measured: 302 of 400 races (0.76; σ of the rate ≈ 0.02), 22 flights a race.
  EXPECT_GE(wins, static_cast<int>(0.70 * kRaces));
  EXPECT_LE(flights, 2 * 12 * kRaces);
}

TEST(RaceRates, AnEqualChallengerRarelyReplacesTheIncumbent) {
  int wins = 0;
  int flights = 0;
  constexpr int kRaces = 400;
  for (int s = 0; s < kRaces; ++s) {
    wins += RaceInTurn({{30.0}, {30.0}}, Standard(), 5000 + s, &flights) == 1 ? 1 : 0;
  }
  // The test at 12 maps has level alpha = 0.05, and the early looks only turn challengers away:
  // an equal challenger wins 15 of 400 races (3.75%, measured), a swap that costs nothing.
  EXPECT_LE(wins, static_cast<int>(0.06 * kRaces));
  // About half the equal challengers are turned away at the first stage (8 flights; a race of
  // 12 maps a side flies 24): 14.9 flights a race, measured.
  EXPECT_LE(flights, 18 * kRaces);
}

TEST(RaceRates, TheBestOfSeveralArmsEndsAsIncumbent) {
  // The defaults (30) against challengers 33, 31, 26 (the best), 29, 28 raced in turn.
  const std::vector<Arm> arms = {{30.0}, {33.0}, {31.0}, {26.0}, {29.0}, {28.0}};
  int best = 0;
  int worse_than_defaults = 0;
  int flights = 0;
  constexpr int kTrials = 300;
  for (int s = 0; s < kTrials; ++s) {
    const int end = RaceInTurn(arms, Standard(), 9000 + s, &flights);
    best += end == 3 ? 1 : 0;
    worse_than_defaults += arms[static_cast<std::size_t>(end)].mean > 30.0 ? 1 : 0;
  }
  // Measured: 228 of 300 (0.76; σ ≈ 0.025), none worse than the defaults.
  EXPECT_GE(best, static_cast<int>(0.7 * kTrials));
  EXPECT_LE(worse_than_defaults, static_cast<int>(0.02 * kTrials));
}

TEST(RaceRates, AFasterButFailingChallengerIsMostlyTurnedAway) {
  // 15% faster, but failing one flight in five (the defaults one in fifty). A challenger can win
  // only after 12 maps without a failure: probability 0.8^12 ≈ 0.07 (measured 13 of 200); one
  // failing two flights in five, 0.6^12 ≈ 0.002 (measured 0 of 200).
  int wins = 0;
  int wins_worse = 0;
  int flights = 0;
  for (int s = 0; s < 200; ++s) {
    wins += RaceInTurn({{30.0, 0.02}, {25.5, 0.2}}, Standard(), 700 + s, &flights) == 1 ? 1 : 0;
    wins_worse +=
        RaceInTurn({{30.0, 0.02}, {25.5, 0.4}}, Standard(), 900 + s, &flights) == 1 ? 1 : 0;
  }
  EXPECT_LE(wins, 30);
  EXPECT_LE(wins_worse, 3);
}

TEST(RunRace, StopsWhenItCannotFly) {
  std::vector<RaceSample> inc;
  std::vector<RaceSample> ch;
  int calls = 0;
  const RaceDecision d = RunRace(Standard(), &inc, &ch, [&](int) {
    ++calls;
    return false;
  });
  EXPECT_EQ(calls, 1);
  EXPECT_EQ(d.verdict, RaceVerdict::kReject);
}

}  // namespace
}  // namespace quadtune::optimizers
