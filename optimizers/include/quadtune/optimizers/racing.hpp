#pragma once
/// \file
/// Racing a challenger against an incumbent on shared instances (common random numbers), in
/// the spirit of SMAC's intensification and irace's racing: a challenger flies the maps the
/// incumbent flew, first a few, and earns more maps only while it stays ahead; it replaces the
/// incumbent only when paired evidence says it is better.
///
/// One race, on n shared instances with values i_j (incumbent) and c_j (challenger), differences
/// d_j = c_j − i_j, and failure flags (a collision or an unfinished flight), looked at after
/// first_maps, 2·first_maps, … instances up to max_maps:
///   - reject when mean(d) >= 0 (the challenger is not better on average so far);
///   - reject when the challenger fails on more instances where the incumbent did not than the
///     other way round, give or take `failure_excess` (0: it must not be worse in finish and
///     collision rate), or on more than `failures` instances in all (an incumbent's bad luck
///     does not excuse a challenger's);
///   - before max_maps, otherwise continue on twice as many instances (at most max_maps);
///   - at max_maps, accept when Wilcoxon's signed-rank test rejects "no difference" in favour of
///     "the challenger is lower" at level `alpha` (one-sided; rank-based, so one unfinished flight
///     scored 1000 does not swamp the test as it swamps a t-test), else reject.
/// Early looks only turn challengers away; a winner has flown every one of max_maps instances,
/// so a point that fails a share q of flights where the incumbent does not wins with
/// probability at most (1 − q)^max_maps, and one no better wins at most a share `alpha`.
/// The same rule applies to every challenger, and to the first incumbent (the defaults).
///
/// Thread safety: free functions over values; RaceOptions is a plain value.

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/optimizers/challenger_model.hpp"

namespace quadtune::optimizers {

/// Which point not raced yet challenges the incumbent next.
enum class ChallengerRule {
  kRanked,   ///< the method's own first: bo, bo_pso by posterior mean; pso, random by f_l
  kTwoPart,  ///< the highest score of a ChallengerModel fit to every flight (challenger_model.hpp)
};
constexpr auto EnumNames(ChallengerRule) {
  return std::array{EnumName{ChallengerRule::kRanked, "ranked"},
                    EnumName{ChallengerRule::kTwoPart, "two_part"}};
}

/// YAML `race:` of an experiment.
struct RaceOptions {
  bool enabled = false;  ///< off: no racing (the trial hands back by `recommend:`)
  int first_maps = 4;    ///< instances of a race's first stage, >= 2
  int max_maps = 12;     ///< instances a winner must fly, >= first_maps
  double alpha = 0.05;   ///< one-sided level of the signed-rank test, in (0, 0.5]
  /// Most failed instances a challenger may have in a race, >= 0 (whatever the incumbent's): a
  /// winner's failure rate is then bounded on its own, not only against the incumbent's.
  int failures = 0;
  /// How many more instances a challenger may fail alone than the incumbent fails alone, >= 0.
  int failure_excess = 0;
  /// A race starts after a round of the method when its first stage keeps the flights spent
  /// racing within this share of the flights flown so far (tuning and racing), in (0, 1).
  double share = 0.5;
  /// Whole races only: a race starts only when every flight it may need fits the flights left
  /// (during the tuning rounds, with a second whole race after it), and the rounds stop where the
  /// flights left would no longer hold one whole race, so the trial's last flights go to races
  /// (then `share` no longer limits them).
  bool reserve = false;
  /// bo_pso: each θ_l is also raced with the incumbent's θ_s (after the one with PSO's best
  /// θ_s), and the two_part model works in the whole space, so a θ_s that PSO prefers for its
  /// f_s but that fails flights does not sink every challenger.
  bool incumbent_short = false;
  /// two_part: the model also proposes a point of its own (ProposeChallenger: a local search of
  /// its score from the incumbent and the flown points), which races when it scores higher than
  /// every flown point not raced yet.
  bool propose = false;
  /// A winner's failure probability under the two_part model fit to every flight of the trial
  /// may exceed the incumbent's by at most this (1: no such check).
  double failure_margin = 1.0;
  /// With `propose`: the proposal lies within this distance of the incumbent in every
  /// coordinate of the unit cube (a trust region; 1: anywhere).
  double propose_radius = 1.0;
  /// A challenger turned away after failing a race map, while faster than the incumbent on the
  /// maps neither failed, is followed by the point halfway between it and the incumbent (in the
  /// unit cube), then halfway again, up to this many halvings (0: none).
  int backoff = 0;
  /// With `backoff`: a halfway point that wins is followed by the point halfway between it and
  /// the challenger that failed, so the halvings bisect towards the edge where the challenger's
  /// failures begin (within the same count of halvings).
  bool bisect = false;
  /// A challenger that wins (not a back-off point) is followed by the point one more such step
  /// on, 2·u_winner − u_previous incumbent in the unit cube (clamped to it), raced at once, and
  /// so on while each wins, up to this many steps in a row (0: none); a step that fails while
  /// faster is backed off as any challenger.
  int extrapolate = 0;
  /// Race flights are told to the method's surrogate (bo, bo_pso: observations of the points
  /// flown, so repeats show the GP what one lucky flight hides).
  bool tell = true;
  ChallengerRule challenger = ChallengerRule::kRanked;  ///< how the next challenger is chosen
  /// two_part: what the failure part shrinks towards (challenger_model.hpp).
  FailurePrior failure_prior = FailurePrior::kConstant;

  friend bool operator==(const RaceOptions&, const RaceOptions&) = default;
};

/// The `race:` field list (documentation, reading and range checks).
const Fields<RaceOptions>& RaceFields();

/// One instance's outcome for one side of a race.
struct RaceSample {
  double value = 0.0;   ///< the objective (lower is better)
  bool failed = false;  ///< a failure that counts against the finish/collision rate
};

enum class RaceVerdict { kContinue, kAccept, kReject };
constexpr auto EnumNames(RaceVerdict) {
  return std::array{EnumName{RaceVerdict::kContinue, "continue"},
                    EnumName{RaceVerdict::kAccept, "accept"},
                    EnumName{RaceVerdict::kReject, "reject"}};
}

/// What one look at a race's evidence decides.
struct RaceDecision {
  RaceVerdict verdict = RaceVerdict::kContinue;
  int maps = 0;                 ///< instances judged; with kContinue, the instances to fly next
  double mean_difference = 0.0; ///< mean(c_j − i_j) over the instances judged
  double p_value = 1.0;         ///< one-sided signed-rank p-value (challenger lower)
  int challenger_failures = 0;       ///< instances failed by the challenger
  int challenger_only_failures = 0;  ///< instances failed by the challenger alone
  int incumbent_only_failures = 0;   ///< instances failed by the incumbent alone
  std::string reason;           ///< a phrase for logs
  bool stopped = false;         ///< the race could not fly its next stage (budget or cancel)
};

/// One-sided p-value of Wilcoxon's signed-rank test of H0 "the differences are symmetric about
/// 0" against H1 "they tend to be negative". Zero differences are dropped; tied magnitudes get
/// their average rank. Exact (sign-flip enumeration by dynamic programming) up to 60 non-zero
/// differences, the normal approximation with tie and continuity corrections beyond. 1 when no
/// difference is non-zero.
double SignedRankPValueLower(const std::vector<double>& differences);

/// Judges a race on the first `maps` instances that both sides have (see the file comment).
/// Needs incumbent.size() >= maps and challenger.size() >= maps, maps >= 1.
RaceDecision JudgeRace(const std::vector<RaceSample>& incumbent,
                       const std::vector<RaceSample>& challenger, int maps,
                       const RaceOptions& options);

/// Runs one race to its verdict. `extend(n)` must make both *incumbent and *challenger hold at
/// least n samples (flying what is missing) and return true, or return false when it cannot
/// (budget spent, cancelled): the race then ends with kReject ("stopped") on what was judged.
RaceDecision RunRace(const RaceOptions& options, const std::vector<RaceSample>* incumbent,
                     const std::vector<RaceSample>* challenger,
                     const std::function<bool(int)>& extend);

}  // namespace quadtune::optimizers
