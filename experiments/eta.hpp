#pragma once
/// \file
/// The progress line's ETA: the measured cost of the work that is left.
///
/// A run's work is counted in two units: flights (long-term evaluations, each a closed-loop
/// flight) and re-solves (recorded planning queries re-solved for a θ_s candidate). WorkPlan
/// counts what an experiment plans: per trial its flights, its re-check flights (the fewest a
/// recommendation needs: recommend.flights) and its re-solves (bo_pso: short_evals_per_flight ×
/// flights × queries_per_eval), then the held-out validation flights.
///
/// EtaEstimator reads the progress reports. Between two reports it sees the wall time spent (ΔT)
/// and the flights and re-solves finished (ΔF, ΔR), and fits ΔT ≈ a·ΔF + b·ΔR by least squares
/// over every pair seen so far (a, b >= 0): a and b are the measured wall seconds per flight and
/// per re-solve at the run's parallelism (flight_batch flights at once, re-solves on every
/// thread). The ETA is a·(flights left) + b·(re-solves left) + a·(validation flights left)·
/// min(flight_batch, threads) / threads (validation flies on every thread at once).
///
/// - While only one kind of work has been measured, the other's cost is unknown: its work left
///   is not charged and the estimate is a lower bound (Eta::lower_bound).
/// - While every report has had the same mix (ΔR/ΔF constant, e.g. a run of bo_pso trials only),
///   a and b cannot be told apart: each kind is charged half of the measured time per flight
///   with its re-solves. The sum is exact for work of the same mix.
/// - Replayed evaluations (--resume) finish almost at once; the fit takes them as cheap work.
/// - Under MPI, a trial on another rank reports once, when it has finished, and its re-solves
///   are not in Progress::short_evals (rank 0's own count): its planned re-solves are counted
///   done then.
///
/// Thread safety: not thread-safe; the progress callback is called from one thread at a time.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "quadtune/engine/experiment.hpp"
#include "quadtune/engine/tuner.hpp"

namespace quadtune::cli {

/// The work one trial plans.
struct PlannedTrial {
  std::string method;
  int repeat = 0;
  int flights = 0;          ///< budget.flights (default: budget.default_flights)
  int recheck_flights = 0;  ///< the fewest re-check flights after the budget (0 for default)
  long resolves = 0;        ///< re-solves (bo_pso only)
};

/// The work of a whole run, in the order it is done.
struct WorkPlan {
  std::vector<PlannedTrial> trials;
  int validation_flights = 0;
  /// Validation flights flown at once over a trial round's flights at once (>= 1).
  double validation_speedup = 1.0;

  /// The plan of `e` run on `threads` worker threads.
  static WorkPlan Of(const engine::Experiment& e, int threads);
};

/// An estimate of the seconds left.
struct Eta {
  double seconds = 0.0;
  bool lower_bound = false;  ///< some work left is of a kind not measured yet
  /// "ETA 42 s", or "ETA > 42 s" for a lower bound.
  [[nodiscard]] std::string Text() const;
};

/// The cost model: ΔT ≈ a·ΔF + b·ΔR fitted over the increments it is given.
class CostFit {
 public:
  /// One increment: `seconds` of wall time in which `flights` flights and `resolves` re-solves
  /// finished. Increments with no work or no time are ignored.
  void Add(double seconds, double flights, double resolves);
  /// Wall seconds per flight (a); < 0 while unknown.
  [[nodiscard]] double FlightCost() const { return Solve().first; }
  /// Wall seconds per re-solve (b); < 0 while unknown.
  [[nodiscard]] double ResolveCost() const { return Solve().second; }
  /// a·flights + b·resolves; work of an unknown cost is left out and flagged.
  [[nodiscard]] Eta Cost(double flights, double resolves) const;

 private:
  [[nodiscard]] std::pair<double, double> Solve() const;
  double ff_ = 0.0, fr_ = 0.0, rr_ = 0.0, ft_ = 0.0, rt_ = 0.0;
};

/// Turns progress reports into the work done and the ETA of the work left.
class EtaEstimator {
 public:
  explicit EtaEstimator(WorkPlan plan);
  /// Takes one progress report (a trial's, or method "validation").
  void Observe(const engine::Progress& p);
  /// Seconds left for the whole run, trials and validation.
  [[nodiscard]] Eta Remaining() const;
  [[nodiscard]] const CostFit& Fit() const { return fit_; }
  /// Flights finished so far (trials with their re-check flights, then validation).
  [[nodiscard]] double FlightsDone() const;

 private:
  [[nodiscard]] double TrialFlightsDone() const;
  WorkPlan plan_;
  double planned_trial_flights_ = 0.0;
  double planned_resolves_ = 0.0;
  std::map<std::pair<std::string, int>, int> flights_;  // (method, repeat) → flights reported
  std::pair<std::string, int> current_{};               // the trial of the last report
  std::map<std::pair<std::string, int>, long> remote_resolves_;  // other ranks' trials, done
  double resolves_ = 0.0;
  double validation_done_ = 0.0;
  double validation_offset_ = -1.0;  // run seconds when validation began (< 0: not yet)
  double last_t_ = 0.0, last_f_ = 0.0, last_r_ = 0.0;
  CostFit fit_;
  CostFit validation_fit_;  // validation flights alone (they run on every thread)
};

}  // namespace quadtune::cli
