#pragma once
/// \file
/// A study: one experiment run at several settings (a sweep) and/or in stages, followed by
/// validation flights of the tuned parameters. It is how the paper's obstacle-density table
/// (Sec. IV-B2: tune at 3.0, 2.1, 1.3 and 0.9 m spacing, then fly the tuned parameters five
/// times) and its refinement with moving bounds (Sec. III-E/IV-C: tune in a low-fidelity world,
/// refine in a high-fidelity one around the result) are expressed.
///
///     name: density
///     seed: 11
///     experiment: density_base.yaml # the base experiment (relative to this file)
///     override: {budget: {...}}     # optional, deep-merged onto the base (maps merge, the rest
///                                   # is replaced)
///     sweep:                        # optional: one point per value
///       key: planner.layout_file    # dotted path into the experiment
///       values: [layouts/forest_3p0.yaml, layouts/forest_2p1.yaml]
///       labels: ["3.0", "2.1"]      # optional, names of the points (default: the values)
///     stages:                       # optional (default: one stage named "tuning")
///       - {name: low_fidelity}
///       - name: high_fidelity
///         override: {planner: {world: {wind: [1, 0, 0]}}}
///         start_from: low_fidelity  # experiment `start:` = that stage's recommended point
///     validation: {flights: 20}     # held-out maps each recommended point flies (0: none)
///
/// RunStudy stores every stage's evaluations in OUT/<label>/<stage>/results.sqlite (a `quadtune
/// run` store, so `--resume` works per stage) and returns the rest as a StudyOutcome, which
/// WriteStudyFiles writes under OUT: study.json (points, stages, parameter bounds, files) and
/// validation.csv: every validation flight, flown in the last stage's world (planner, map
/// density, noise) with the recommended point of each trial of every stage (TrialSummary::
/// recommended) and with the defaults, all on the same held-out maps and flight seeds
/// (Experiment::HeldOutMapSeed / HeldOutFlightSeed of the last stage: maps of the same kind
/// that no trial flew). The runs inside a study skip their own validation.
///
/// Thread safety: a Study is an immutable value; RunStudy uses the threads it is given and calls
/// `on_update` on the thread that called it.

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/tuning/tuner.hpp"

namespace quadtune::engine {

/// One stage of a study point: an experiment text and where its start point comes from.
struct StudyStage {
  std::string name;
  std::string start_from;     ///< name of an earlier stage, or ""
  std::string override_yaml;  ///< the stage's override (YAML text, may be empty)
};

/// A loaded, checked study.
struct Study {
  std::string file;
  std::string experiment_file;  ///< `experiment` as written
  std::string name = "study";
  std::uint64_t seed = 1;
  std::string base_text;       ///< the base experiment after the study-wide override (YAML)
  std::string base_dir;        ///< folder of the base experiment (relative paths resolve there)
  std::string sweep_key;       ///< "" when there is no sweep
  std::vector<std::string> sweep_values;  ///< YAML scalars as written
  std::vector<std::string> labels;        ///< one per point (a single "all" without a sweep)
  std::vector<StudyStage> stages;
  int validation_flights = 20;

  /// Reads and checks a study file: every point and stage is built into an Experiment (so every
  /// configuration error surfaces before any work), errors name the file and the key.
  static Study LoadFile(const std::string& path);
  /// As LoadFile, with "dotted.key=value" assignments (`quadtune study --set`) applied to the
  /// study file's text first, e.g. override.budget.flights=10 or validation.flights=2.
  static Study LoadFile(const std::string& path, const std::vector<std::string>& assignments);
  /// The experiment of `point` and `stage`, with `start` (if not empty) as its `start:`.
  [[nodiscard]] Experiment Build(std::size_t point, std::size_t stage,
                                 const ParamValues& start = {}) const;
};

/// The study file (StudyFields reads it into a Study whose `file` is set; LoadFile then builds
/// every point and stage) and its sections: `sweep:`, each item of `stages:`, `validation:`.
const Fields<Study>& StudyFields();
const Fields<Study>& StudySweepFields();
const Fields<StudyStage>& StudyStageFields();
const Fields<Study>& StudyValidationFields();

/// Progress of a study.
struct StudyProgress {
  std::string label, stage;
  std::size_t point = 0, points = 0;
  Progress run;                ///< of the stage's tuning run
  bool validating = false;
  int validation_done = 0, validation_total = 0;
};

struct StudySummary {
  RunStatus status = RunStatus::kCompleted;
  double wall_s = 0.0;
  long flights = 0;  ///< tuning and validation flights flown
  long resolves = 0;
};

/// One stage of a study point as it ran (an entry of study.json).
struct StudyStageResult {
  std::string name;
  std::string start_from;  ///< StudyStage::start_from
  ParamValues start;       ///< the stage's `start:` (empty: none)
  std::string store;       ///< its results.sqlite, relative to StudyOptions::out_dir
  ParamValues best;        ///< the best recommended point of its tuned trials, else the defaults
  double wall_s = 0.0;
  std::vector<optimizers::Parameter> space;  ///< the stage's tuned parameters and bounds
};

/// A study point whose stages have all run.
struct StudyPointResult {
  std::string label;
  std::string value;  ///< the sweep value as written (YAML), "" without a sweep
  std::vector<StudyStageResult> stages;
};

/// One validation flight (a row of validation.csv).
struct StudyValidationFlight {
  std::size_t point = 0;
  std::string label;
  std::string source_stage;  ///< the stage whose trial recommended `params`; "" for the defaults
  std::string method;        ///< "default" for the defaults
  int repeat = 0;
  std::size_t flight = 0;  ///< index of the held-out map
  std::uint64_t map_seed = 0;
  EvalStatus status = EvalStatus::kOk;
  bool completed = false;
  double flight_time = 0.0;
  int collisions = 0;
  int emergency_stops = 0;
  int plans = 0;
  int failed_plans = 0;
  double f_l = 0.0;    ///< long-term objective (failure_value unless the flight was ok)
  ParamValues params;  ///< the candidate's parameters (the rest at their defaults)
};

/// What a study produced besides its stores: the points whose stages finished and the
/// validation flights of the points validated, in order, with the study's identity.
struct StudyOutcome {
  StudySummary summary;
  std::string name;
  std::string file;
  std::uint64_t seed = 1;
  std::string sweep_key;
  int validation_flights = 0;
  std::vector<StudyPointResult> points;
  std::vector<StudyValidationFlight> validation;
};

struct StudyOptions {
  std::string out_dir = "results/study";  ///< the stage stores go under it
  int threads = 0;             ///< > 0 overrides the experiments' threads
  bool resume = false;         ///< continue stored stages; stages already done are replayed
  std::function<void(const StudyProgress&)> on_progress;  ///< may be empty
  /// Called with the outcome so far when the study starts and whenever it grows (a point's
  /// stages finished, a point validated); may be empty. `quadtune study` writes the files
  /// (WriteStudyFiles) there, so a study killed on the way leaves those of the finished points.
  std::function<void(const StudyOutcome&)> on_update;
  const std::atomic<bool>* cancel = nullptr;
};

/// Runs the study (see the file comment) and returns its outcome; a cancelled study returns
/// what it finished (summary.status kCancelled). Configuration problems throw ConfigError
/// before any work; failures inside flights are recorded in the stores and in the outcome's
/// validation flights.
StudyOutcome RunStudy(const Study& study, const StudyOptions& options);

/// Writes `outcome` under `out_dir` (which must exist): validation.csv (a header and one row per
/// validation flight) and, once a point's stages have finished, study.json. Throws
/// std::filesystem::filesystem_error when a file cannot be written.
void WriteStudyFiles(const StudyOutcome& outcome, const std::string& out_dir);

}  // namespace quadtune::engine
