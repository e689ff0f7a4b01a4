#include "quadtune/optimizers/racing.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace quadtune::optimizers {
namespace {

constexpr std::size_t kExactLimit = 60;

/// Ranks of |d| (1-based, ties averaged), doubled so that every rank is an integer.
std::vector<long> DoubledRanks(const std::vector<double>& magnitudes) {
  const std::size_t n = magnitudes.size();
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return magnitudes[a] < magnitudes[b]; });
  std::vector<long> doubled(n);
  for (std::size_t i = 0; i < n;) {
    std::size_t j = i;
    while (j + 1 < n && magnitudes[order[j + 1]] == magnitudes[order[i]]) ++j;
    const auto sum_of_ranks = static_cast<long>((i + 1) + (j + 1));  // 2 × average rank
    for (std::size_t k = i; k <= j; ++k) doubled[order[k]] = sum_of_ranks;
    i = j + 1;
  }
  return doubled;
}

/// P(W⁺ <= observed) under random signs, W⁺ in doubled-rank units, by counting sign patterns.
double ExactLowerTail(const std::vector<long>& ranks, long observed) {
  const long total = std::accumulate(ranks.begin(), ranks.end(), 0L);
  std::vector<double> ways(static_cast<std::size_t>(total) + 1, 0.0);
  ways[0] = 1.0;
  long reach = 0;
  for (long r : ranks) {
    for (long s = reach; s >= 0; --s) ways[static_cast<std::size_t>(s + r)] += ways[static_cast<std::size_t>(s)];
    reach += r;
  }
  double below = 0.0;
  for (long s = 0; s <= std::min(observed, total); ++s) below += ways[static_cast<std::size_t>(s)];
  return below / std::pow(2.0, static_cast<double>(ranks.size()));
}

/// The normal approximation of P(W⁺ <= observed) with the tie and continuity corrections.
double NormalLowerTail(const std::vector<long>& doubled, long observed) {
  double mean = 0.0;
  double var = 0.0;
  for (long r2 : doubled) {
    const double r = 0.5 * static_cast<double>(r2);
    mean += 0.5 * r;
    var += 0.25 * r * r;
  }
  const double w = 0.5 * static_cast<double>(observed);
  const double z = (w + 0.5 - mean) / std::sqrt(var);
  return 0.5 * std::erfc(-z / std::sqrt(2.0));
}

}  // namespace

const Fields<RaceOptions>& RaceFields() {
  using R = RaceOptions;
  static const Fields<R> fields =
      Fields<R>()
          .Flag("enabled", &R::enabled,
                "race challengers against an incumbent (at first the defaults) on shared race "
                "maps during tuning; the trial hands back its incumbent (`recommend.candidates` "
                "must then be 0)")
          .Integer("first_maps", &R::first_maps, Range::Closed(2, 1000),
                   "race maps a challenger flies first; each stage it stays ahead doubles them "
                   "(at most `max_maps`)")
          .Integer("max_maps", &R::max_maps, Range::Closed(2, 1000),
                   "race maps a challenger must fly to replace the incumbent (>= `first_maps`): "
                   "the signed-rank test is applied there; no significant win keeps the "
                   "incumbent")
          .Integer("failures", &R::failures, Range::Closed(0, 1000),
                   "most race maps a challenger may fail (collide or not finish) and still win, "
                   "whatever the incumbent did; it must also fail no more maps than the "
                   "incumbent on the shared maps, give or take `failure_excess`")
          .Integer("failure_excess", &R::failure_excess, Range::Closed(0, 1000),
                   "how many more of the shared maps a challenger may fail than the incumbent "
                   "fails (0: no more); `failures` still bounds its own")
          .Number("alpha", &R::alpha, Range{0.0, 0.5, true, false},
                  "one-sided level of Wilcoxon's signed-rank test on the paired differences of "
                  "f_l that a challenger must pass to replace the incumbent")
          .Number("share", &R::share, Range::OpenUnit(),
                  "a race starts after a round when its first stage keeps racing flights within "
                  "this share of the flights flown so far; every racing flight counts against "
                  "`budget.flights`")
          .Flag("reserve", &R::reserve,
                "whole races only: a race starts only when all the flights it may need fit the "
                "flights left (during the tuning rounds, with a second whole race after it), and "
                "the rounds stop where one whole race no longer would, so the trial's last "
                "flights race its best points (`share` does not limit those)")
          .Flag("incumbent_short", &R::incumbent_short,
                "`bo_pso`: each θ_l also challenges with the incumbent's θ_s, besides PSO's best, "
                "and the `two_part` model works in the whole space")
          .Flag("propose", &R::propose,
                "`two_part`: the model also proposes a point no flight has flown (a local search "
                "of its score from the incumbent and the flown points, and random points); it "
                "races when it scores higher than every flown point not raced yet")
          .Number("propose_radius", &R::propose_radius, Range{0.0, 1.0, true, false},
                  "with `propose`: the proposed point lies within this distance of the "
                  "incumbent in every coordinate of the unit cube (1: anywhere)")
          .Number("failure_margin", &R::failure_margin, Range::Closed(0.0, 1.0),
                  "a challenger that wins its race replaces the incumbent only when its failure "
                  "probability under the `two_part` failure model, fit to every flight of the "
                  "trial (its race flights included), exceeds the incumbent's by at most this "
                  "(1: no such check)")
          .Integer("backoff", &R::backoff, Range::Closed(0, 10),
                   "a challenger turned away after failing a race map, while faster than the "
                   "incumbent on the maps neither side failed, is followed by the point halfway "
                   "between it and the incumbent in the unit cube, then halfway again, up to this "
                   "many halvings (0: none)")
          .Flag("bisect", &R::bisect,
                "with `backoff`: a halfway point that wins is followed by the point halfway "
                "between it and the challenger that failed, bisecting towards the edge where the "
                "failures begin (within the same count of halvings)")
          .Integer("extrapolate", &R::extrapolate, Range::Closed(0, 10),
                   "a challenger that wins (not a back-off point) is followed by the point one "
                   "more such step on, 2·u_winner − u_previous in the unit cube (clamped to it), "
                   "raced at once; up to this many steps in a row while each wins (0: none)")
          .Flag("tell", &R::tell,
                "race flights are told to the method's surrogate (`bo`, `bo_pso`: observations "
                "of the points flown), so repeats correct what one lucky flight suggested")
          .Choice("challenger", &R::challenger,
                  "which point not raced yet challenges the incumbent: `ranked`, the method's "
                  "first (`bo`, `bo_pso`: lowest posterior mean; `pso`, `random`: lowest f_l); "
                  "`two_part`, the highest chance of flying `max_maps` maps within `failures` "
                  "failures times expected improvement on the incumbent, from a GP on the "
                  "finished flights and a kernel failure rate fit to every flight, race flights "
                  "included")
          .Choice("failure_prior", &R::failure_prior,
                  "what the kernel failure rate of `two_part` and `failure_margin` shrinks "
                  "towards: `constant`, the trial's overall failure rate, weight one flight; "
                  "`logistic`, a logistic regression of failure on the parameters, weight 1, 4 "
                  "or 16 flights by leave-one-out likelihood, so a point's few clean flights do "
                  "not hide the failures of the faster points around it");
  return fields;
}

double SignedRankPValueLower(const std::vector<double>& differences) {
  std::vector<double> magnitudes;
  std::vector<bool> positive;
  for (double d : differences) {
    if (d == 0.0 || !std::isfinite(d)) continue;
    magnitudes.push_back(std::abs(d));
    positive.push_back(d > 0.0);
  }
  if (magnitudes.empty()) return 1.0;
  const std::vector<long> doubled = DoubledRanks(magnitudes);
  long observed = 0;  // W⁺ in doubled units: small when the differences are negative
  for (std::size_t i = 0; i < doubled.size(); ++i) {
    if (positive[i]) observed += doubled[i];
  }
  if (doubled.size() <= kExactLimit) return ExactLowerTail(doubled, observed);
  return NormalLowerTail(doubled, observed);
}

RaceDecision JudgeRace(const std::vector<RaceSample>& incumbent,
                       const std::vector<RaceSample>& challenger, int maps,
                       const RaceOptions& options) {
  QT_DEMAND(maps >= 1 && static_cast<int>(incumbent.size()) >= maps &&
                static_cast<int>(challenger.size()) >= maps,
            "JudgeRace needs both sides on the judged maps");
  RaceDecision d;
  d.maps = maps;
  std::vector<double> diff;
  for (int j = 0; j < maps; ++j) {
    const auto& i = incumbent[static_cast<std::size_t>(j)];
    const auto& c = challenger[static_cast<std::size_t>(j)];
    diff.push_back(c.value - i.value);
    d.mean_difference += diff.back() / maps;
    d.challenger_failures += c.failed ? 1 : 0;
    d.challenger_only_failures += c.failed && !i.failed ? 1 : 0;
    d.incumbent_only_failures += i.failed && !c.failed ? 1 : 0;
  }
  d.p_value = SignedRankPValueLower(diff);
  if (!(d.mean_difference < 0.0)) {
    d.verdict = RaceVerdict::kReject;
    d.reason = "not better on average";
  } else if (d.challenger_only_failures > d.incumbent_only_failures + options.failure_excess ||
             d.challenger_failures > options.failures) {
    d.verdict = RaceVerdict::kReject;
    d.reason = "fails more maps";
  } else if (maps >= options.max_maps) {
    d.verdict = d.p_value <= options.alpha ? RaceVerdict::kAccept : RaceVerdict::kReject;
    d.reason = d.p_value <= options.alpha ? "better" : "not significantly better";
  } else {
    d.maps = std::min(2 * maps, options.max_maps);
    d.reason = "ahead, not yet significant";
  }
  return d;
}

RaceDecision RunRace(const RaceOptions& options, const std::vector<RaceSample>* incumbent,
                     const std::vector<RaceSample>* challenger,
                     const std::function<bool(int)>& extend) {
  int maps = std::min(options.first_maps, options.max_maps);
  RaceDecision last;
  while (true) {
    if (!extend(maps)) {
      last.verdict = RaceVerdict::kReject;
      last.reason = "stopped (budget or cancel)";
      last.stopped = true;
      return last;
    }
    last = JudgeRace(*incumbent, *challenger, maps, options);
    if (last.verdict != RaceVerdict::kContinue) return last;
    maps = last.maps;
  }
}

}  // namespace quadtune::optimizers
