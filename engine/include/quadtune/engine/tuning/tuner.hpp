#pragma once
/// \file
/// The tuner: runs every trial (method × repeat) of an experiment on the scheduler and stores
/// every evaluation.
///
/// Methods (paper Sec. IV-A): default; random, pso, bo (all parameters scored by f_l); bo_pso,
/// the complementary tuner (paper Sec. III): BayesOpt on θ_l scored by flights; PSO on θ_s scored
/// by f_s on planning queries recorded from the flights; the best θ_s flows into later flights
/// (flight hook); BO discounts observations made under an older θ_s (NotifyContextChanged for
/// each round whose flying θ_s differs from the previous round's; the n_d in force is stored
/// with each flight as term "n_d"). With no initial θ_s a first flight with the defaults
/// records queries and PSO runs on them before BO starts.
///
/// Maps: flight k of a trial (counted over the trial: 0, 1, …) flies map
/// Experiment::FlightMapSeed(repeat, k), the same for every method (common random numbers);
/// each stored flight records its map seed and flight seed.
///
/// Rounds. Each round asks a fixed batch of `budget.flight_batch` candidates and flies them
/// (priority: flights) while, in bo_pso, PSO generations re-solve queries recorded in earlier
/// rounds (priority: short). Results are applied to the optimisers in index order at the end of
/// the round, never in completion order.
///
/// Reproducible mode: batch sizes come from the experiment, not the thread count; every flight
/// seed is DeriveSeed(trial seed, {iteration, index}); every θ_s candidate of one PSO
/// generation re-solves the same queries, drawn with DeriveSeed(trial seed, {generation}) from
/// the buffer as it stood at the start of the round (candidates compared on one problem set); t_c comes from compute units; a flight's θ_s is fixed when it starts. So
/// the same seed gives identical results with 1, 2 or 8 threads. Realtime mode measures t_c by
/// the wall clock and lets running flights pick up a new best θ_s at their next plan.
///
/// Resume: evaluations already in the store are replayed (their stored values told in the same
/// order) instead of being computed; bo_pso flights whose queries are still needed are flown
/// again (deterministic in reproducible mode) to rebuild the query buffer.
///
/// Failures: an exception in a flight or re-solve is caught at the evaluation boundary and
/// recorded (status failed, message); the optimiser is told objective.failure_value.
///
/// Racing (experiment `race:`, optimizers/racing.hpp): a tuned trial keeps an incumbent, at
/// first its defaults. After a round, when the race's first stage keeps racing flights within
/// race.share of the trial's flights, the method's best candidate not raced yet races the
/// incumbent on the repeat's race maps (Experiment::RaceMapSeed/RaceFlightSeed: the same maps and
/// world seeds for both sides and every method); a challenger that wins replaces the incumbent,
/// and with race.tell every race flight is an observation of bo's or bo_pso's GP. Race flights are
/// stored as kind "race" (iteration = race, index = flight within it), each race's outcome as
/// kind "incumbent" (iteration = race, index 0); every flight counts against budget.flights,
/// and tuning flight k still flies FlightMapSeed(repeat, k) with k counting tuning flights only.
/// The trial hands back its incumbent.
///
/// Validation: RunExperiment ends, when options.validate and experiment.validation.maps > 0, by
/// flying each trial's recommended point and the defaults on the held-out maps (validation.hpp),
/// stored as kind 'validation' rows (iteration = map index) under the trial's id, the defaults'
/// under trial id 0; resumable like the rest.
///
/// RunExperiment runs every trial in order on one TrialRunner. A distributed run (MPI,
/// distributed.hpp) gives each rank a TrialRunner and hands it whole trials; a trial computes
/// the same evaluations wherever it runs.
///
/// Room engine/tuning: its files include engine headers of this room, api, experiment and store
/// only (scripts/check_rooms.py; docs/design.md, "Architecture").
///
/// Thread safety: RunExperiment and a TrialRunner are driven by one thread; they run the
/// evaluations on the scheduler's worker threads.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "quadtune/common/columns.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/tuning/validation.hpp"

namespace quadtune::engine {

/// Progress reported after every round.
struct Progress {
  std::string method;
  int repeat = 0;
  int flights_done = 0;          ///< in this trial
  int flights_total = 0;         ///< per trial
  int trials_done = 0;
  int trials_total = 0;
  long short_evals = 0;          ///< re-solves run so far (all trials)
  double best_long = 0.0;        ///< best f_l of this trial so far
  double elapsed_s = 0.0;
  int rank = 0;                  ///< MPI rank that runs the trial (distributed runs)
};

/// How to run.
struct RunOptions {
  std::string store_path;           ///< SQLite file ("" → no store; results only in memory)
  int threads = 0;                  ///< > 0 overrides the experiment's threads
  bool resume = false;              ///< continue the run stored in store_path
  std::function<void(const Progress&)> on_progress;  ///< may be empty
  const std::atomic<bool>* cancel = nullptr;          ///< set → stop after the current round
  /// End with the held-out validation (experiment.validation.maps > 0); a study turns it off
  /// and validates across its stages itself.
  bool validate = true;
};

/// Outcome of a run.
enum class RunStatus { kCompleted, kCancelled };
constexpr auto EnumNames(RunStatus) {
  return std::array{EnumName{RunStatus::kCompleted, "completed"},
                    EnumName{RunStatus::kCancelled, "cancelled"}};
}

/// Best result of one trial.
struct TrialSummary {
  std::string method;
  int repeat = 0;
  std::int64_t trial_id = 0;  ///< the store's id of the trial (0 without a store)
  ParamValues best;         ///< parameters of the best flight (all of θ_s ∪ θ_l)
  /// Best f_l of a completed flight; while none has completed, the best failed one's value
  /// (objective.failure_value), and `best` its parameters.
  double best_value = 0.0;
  /// The point the method recommends (what validation flies). With racing, the incumbent at the
  /// end of the budget. Without it: candidates, best first: bo, the
  /// observed points by posterior mean (BayesOpt::Ranked), not the luckiest flight; bo_pso, those
  /// for θ_l with PSO's final best θ_s; pso and random, the flights by f_l. Without re-flights
  /// (recommend.candidates 0) the first candidate; with them, the first candidate whose every
  /// re-flight passes (RecommendOptions), else the defaults. default: the defaults.
  ParamValues recommended;
  /// With racing: the incumbent's mean f_l on the race maps it flew (+∞ when it flew none).
  /// Without re-flights: bo and bo_pso, the posterior mean at `recommended`, the others
  /// best_value. With them: the mean f_l of the passing candidate's re-flights; +∞ when none
  /// passed.
  double recommended_value = 0.0;
  /// With re-flights: the rank (0 = best) of the candidate that passed; -1 when none passed or
  /// none were flown. With racing: 0 when a challenger won, -1 when the defaults are kept.
  int recommended_rank = -1;
  int recheck_flights = 0;  ///< re-flights flown (or replayed) to pick `recommended`
  int flights = 0;          ///< every flight of the trial (tuning and racing)
  int short_evals = 0;      ///< θ_s candidates scored (PSO); each re-solves queries_per_eval queries
  int failed = 0;           ///< failed evaluations
  int replayed = 0;         ///< evaluations taken from the store on resume
  int races = 0;             ///< races run (race.enabled)
  int race_flights = 0;      ///< flights flown (or replayed) in races; included in `flights`
  int incumbent_changes = 0; ///< races the challenger won
  /// bo_pso: n_d, BayesOpt::NotifyContextChanged() calls: one per change of the θ_s that flies
  /// (a round whose θ_s differs from the previous round's).
  int context_changes = 0;
};

/// The one list of TrialSummary's fields (columns.hpp): the JSON of the distributed path and
/// the trials of `summary.json` follow it.
const Columns<TrialSummary>& TrialSummaryColumns();

struct RunSummary {
  RunStatus status = RunStatus::kCompleted;
  std::string message;
  std::vector<TrialSummary> trials;
  long flights = 0;         ///< flights flown in this process
  long resolves = 0;        ///< query re-solves run in this process
  double wall_s = 0.0;
  int threads = 0;
  int worlds = 0;           ///< world-pool slots created
  int ranks = 1;            ///< MPI ranks (distributed runs; threads is per rank)
  /// Held-out validation (RunOptions::validate): the defaults first, then each trial's
  /// recommended point; empty when not validated.
  std::vector<ValidationSummary> validation;
};

class EvaluationStore;

/// Runs single trials on its own scheduler and world pool; the maps of every repeat are made
/// when it is built (so a layout that cannot be generated stops the run before any work).
class TrialRunner {
 public:
  /// `threads` >= 1 workers. `store` (may be null: results only in memory) must outlive the
  /// runner. options.store_path only names the store in errors; options.threads is ignored.
  TrialRunner(const Experiment& experiment, const RunOptions& options, int threads,
              EvaluationStore* store);
  ~TrialRunner();
  TrialRunner(const TrialRunner&) = delete;
  TrialRunner& operator=(const TrialRunner&) = delete;

  /// Runs trial (method, repeat) into `summary`; false when cancelled (options.cancel).
  /// Throws ConfigError when the stored rows do not fit the run (see RunExperiment).
  bool Run(Method method, int repeat, TrialSummary& summary);
  /// What progress reports show as trials done / total (thread-safe).
  void SetTrialCounts(int done, int total);
  [[nodiscard]] long Flights() const;   ///< flights flown so far
  [[nodiscard]] long Resolves() const;  ///< query re-solves run so far
  [[nodiscard]] int Worlds() const;     ///< world-pool slots created
  [[nodiscard]] double ElapsedSeconds() const;  ///< since the runner was built

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Flies the defaults and every trial's recommended point (`trials`, with the trial ids the
/// store gave them, 0 when there is no store) on experiment.validation.maps held-out maps, all
/// on the same maps and flight seeds. Rows already in `store` (kind 'validation') are replayed,
/// new ones stored; the defaults' rows have trial id 0. The defaults are flown once even when
/// the experiment has a `default` method (its trials recommend the defaults and reuse them).
/// Returns one summary per parameter set, the defaults first; an empty vector when cancelled.
/// `flown` (may be null) receives the number of flights flown (not replayed).
std::vector<ValidationSummary> RunValidation(const Experiment& experiment,
                                             const std::vector<TrialSummary>& trials,
                                             const std::vector<std::int64_t>& trial_ids,
                                             EvaluationStore* store, int threads,
                                             const RunOptions& options, long* flown = nullptr);

/// Runs `experiment`. Configuration problems (e.g. resuming another run) throw ConfigError
/// before any work starts; failures inside evaluations are recorded, never thrown.
RunSummary RunExperiment(const Experiment& experiment, const RunOptions& options = {});

}  // namespace quadtune::engine
