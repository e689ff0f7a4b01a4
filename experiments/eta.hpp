#pragma once
/// \file
/// The progress line's ETA: the measured cost of the work that is left.
///
/// A job (`quadtune run`: one experiment; `quadtune study`: one experiment per point and stage,
/// numbered runs 0, 1, … in the order they are done) is counted in three kinds of work: trial
/// flights (long-term evaluations), re-solves (recorded planning queries re-solved for a θ_s
/// candidate) and plain flights of fixed parameters (re-check flights after a trial's budget:
/// recommend.flights, the fewest a recommendation needs; held-out validation flights). WorkPlan
/// lists the job's trials in order, each with its flights, re-check flights and re-solves
/// (bo_pso: short_evals_per_flight × flights × queries_per_eval), and the validation blocks.
///
/// EtaEstimator reads the progress reports with the job's wall clock. Between two reports it
/// sees the wall time spent (ΔT) and the work finished (ΔF flights, ΔR re-solves) and keeps
/// least-squares fits ΔT ≈ a·ΔF + b·ΔR (CostFit, a, b >= 0):
/// - one per method, from the increments inside that method's trials (its optimizer's overhead,
///   the parameters it flies and, for bo_pso, its re-solves running beside its flights are in
///   its own rates);
/// - a pooled one over every increment: the cost of a method not measured yet, and of re-check
///   flights before any tail has been measured;
/// - one for validation flights, which fly on every thread at once; before it has an increment,
///   the pooled flight cost divided by the validation's speed-up.
/// The increment from a trial's last report to the next report (a handover) holds the trial's
/// tail (its re-check flights, as many as its candidates needed, often more than the fewest)
/// and the next work's first round; the tail is the handover's time less that round's cost at
/// the fitted rates, and a method's trials left are charged the mean tail measured for it
/// (before one is measured: the fewest re-check flights at the pooled flight cost).
/// The ETA sums, trial by trial, the flights and re-solves left at the trial method's rates and
/// the tails left, then the validation flights left, then the figures and the report drawn when
/// the job has ended (PlannedDrawing: the stored flights the report flies again, one at a time,
/// each at the pooled flight cost times the flights a trial round flies at once, and a nominal
/// kScriptSeconds for the figure and report scripts, which no report measures). Time before the
/// first report (the job's start: store, first maps) is not projected.
///
/// A trial whose budget's flights are all reported has no re-solves left (its rounds re-solve
/// before they report), and a validation reported with fewer flights in all than planned flies
/// only those: on --resume the stored ones are replayed, not counted again. Finished() (the
/// job's trials and validation have returned) leaves the drawing only.
///
/// - Work of a kind no fit has measured (re-solves before any bo_pso report) is not charged and
///   the estimate is a lower bound (Eta::lower_bound).
/// - While a fit has seen one mix only (ΔR/ΔF constant, e.g. bo_pso's own fit), a and b cannot
///   be told apart: each kind is charged half of the measured time per flight with its
///   re-solves. The sum is exact for work of the same mix.
/// - Replayed evaluations (--resume) finish almost at once; the fits take them as cheap work.
/// - Under MPI, a trial on another rank reports once, when it has finished, and its re-solves
///   are not in Progress::short_evals (rank 0's own count): its planned work is counted done
///   then, and from the first such report on, every trial is costed with the pooled fit (the
///   increments no longer belong to one method).
///
/// Thread safety: not thread-safe; the progress callback is called from one thread at a time.

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/tuning/study.hpp"
#include "quadtune/engine/tuning/tuner.hpp"

namespace quadtune::cli {

/// The work one trial plans.
struct PlannedTrial {
  std::string method;
  int repeat = 0;
  int flights = 0;          ///< budget.flights (default: budget.default_flights)
  int recheck_flights = 0;  ///< the fewest re-check flights after the budget (0 for default)
  long resolves = 0;        ///< re-solves (bo_pso only)
  int run = 0;              ///< the experiment of the job it belongs to (0 for `run`)
};

/// Validation flights flown after the trials of run `run`.
struct PlannedValidation {
  int run = 0;
  int flights = 0;
  /// Validation flights flown at once over a trial round's flights at once (>= 1).
  double speedup = 1.0;
};

/// The figures and the report drawn when the job has ended (run and study without --no-plot).
struct PlannedDrawing {
  bool on = false;
  int replay_flights = 0;  ///< stored flights `quadtune report` flies again, one at a time
  /// Trial flights flown at once (a lone flight takes as long as this many at the pooled rate).
  double flights_at_once = 1.0;
};

/// Nominal seconds of the figure script and the report script together (Python start and
/// matplotlib, nearly independent of the store's size), charged while they are ahead; no
/// progress report measures them. Measured on the 2-core development machine: 2.2 s + 0.2 s
/// for tiny.yaml's run, 3.2 s + 0.4 s for the main job's store of 4 677 evaluations (`time
/// quadtune plot run DIR`, `time python3 experiments/report/quadtune_report.py DIR`).
inline constexpr double kScriptSeconds = 3.0;

/// The work of a whole job, in the order it is done.
struct WorkPlan {
  std::vector<PlannedTrial> trials;
  std::vector<PlannedValidation> validations;
  PlannedDrawing drawing;

  /// The plan of `e` run on `threads` worker threads (`quadtune run`: run 0, then the
  /// experiment's own held-out validation).
  static WorkPlan Of(const engine::Experiment& e, int threads);
  /// The plan of a study: per point, its stages as runs point·stages + stage (each without its
  /// own validation), then the point's validation flights (every tuned trial of its stages and
  /// the defaults, Study::validation_flights each). `threads` > 0 overrides the experiments'.
  static WorkPlan Of(const engine::Study& s, int threads);
  /// Appends the trials of `e` as run `run`; returns the number of tuned (non-default) trials.
  int AddTrials(const engine::Experiment& e, int run);
  /// Plans the figures and the report of `quadtune report`'s default --flights 3: as many
  /// stored flights flown again as there are stores × methods, at most 3. `e` is the (last)
  /// experiment, run on `threads` threads.
  void AddDrawing(const engine::Experiment& e, int threads, int stores);
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
  /// Whether any increment has been added.
  [[nodiscard]] bool Empty() const { return ff_ <= 0.0 && rr_ <= 0.0; }
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
  /// Takes one progress report of run `run` (a trial's, or method "validation" with
  /// flights_done counting that validation's flights) at `now_s` seconds of the job's wall
  /// clock. Reports of trials or runs the plan does not hold are ignored.
  void Observe(const engine::Progress& p, double now_s, int run = 0);
  /// The job's trials and validation have returned (completed): none of their work is left,
  /// whatever the reports said (e.g. a resumed job whose stored work was replayed).
  void Finished();
  /// Seconds left for the whole job: trials, re-checks, validation, figures and report.
  [[nodiscard]] Eta Remaining() const;
  /// The fit over every trial increment.
  [[nodiscard]] const CostFit& Pooled() const { return pooled_; }
  /// The fit of `method`'s trials; nullptr before its first increment.
  [[nodiscard]] const CostFit* MethodFit(const std::string& method) const;
  /// Flights finished so far (trials with their re-check flights, then validation).
  [[nodiscard]] double FlightsDone() const;
  /// Flights the plan holds (trials with their fewest re-check flights, validation).
  [[nodiscard]] double FlightsPlanned() const;

 private:
  [[nodiscard]] int TrialIndex(int run, const std::string& method, int repeat) const;
  /// Whether trial `i` has flown its re-check flights (finished and no longer reporting).
  [[nodiscard]] bool RechecksDone(std::size_t i) const;
  [[nodiscard]] double ResolvesDone() const;
  /// Cost of `flights` and `resolves` of `method`'s trials.
  [[nodiscard]] Eta TrialCost(const std::string& method, double flights, double resolves) const;
  /// Cost of `flights` flights of validation `v`.
  [[nodiscard]] Eta ValidationCost(std::size_t v, double flights) const;
  /// Mean measured tail of `method`'s trials (seconds from a trial's last report to the end of
  /// its re-check flights); < 0 while none has been measured.
  [[nodiscard]] double Tail(const std::string& method) const;
  /// Cost of the figures and the report (0 when the plan draws none).
  [[nodiscard]] Eta DrawingCost() const;
  void ObserveValidation(const engine::Progress& p, double now_s, int run);

  /// The increment from a finished trial's last report to the next report of other work: the
  /// trial's tail, then `flights` and `resolves` of `next` (a method, or "validation" v).
  struct Handover {
    std::string method;  // the finished trial's ("" at the job's start)
    double seconds = 0.0;
    std::string next;
    double flights = 0.0, resolves = 0.0;
    std::size_t validation = 0;
  };

  WorkPlan plan_;
  std::vector<int> flights_;          // per planned trial: flights reported
  std::vector<double> resolves_;      // per planned trial: re-solves attributed to it
  std::vector<double> validated_;     // per planned validation: flights reported
  int current_ = -1;                  // the trial of the last report (-1: none, or validating)
  std::map<int, long> run_resolves_;  // per run: its re-solve counter at the last report
  bool distributed_ = false;          // a report from another MPI rank has been seen
  double last_t_ = 0.0;
  std::map<std::string, CostFit> method_fits_;
  CostFit pooled_;
  CostFit validation_fit_;
  std::vector<Handover> handovers_;
  bool finished_ = false;  // Finished(): only the drawing is left
};

}  // namespace quadtune::cli
