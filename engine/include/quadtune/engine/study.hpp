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
/// Outputs under OUT: study.json (points, stages, parameter bounds, files), per point and stage
/// OUT/<label>/<stage>/results.sqlite (a `quadtune run` store, so `--resume` works per stage),
/// and validation.csv: every validation flight, flown in the last stage's world (planner, map
/// density, noise) with the recommended point of each trial of every stage (TrialSummary::
/// recommended) and with the defaults, all on the same held-out maps and flight seeds
/// (Experiment::HeldOutMapSeed / HeldOutFlightSeed of the last stage: maps of the same kind
/// that no trial flew). The runs inside a study skip their own validation.
///
/// Thread safety: a Study is an immutable value; RunStudy uses the threads it is given.

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/engine/experiment.hpp"
#include "quadtune/engine/tuner.hpp"

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

struct StudyOptions {
  std::string out_dir = "results/study";
  int threads = 0;             ///< > 0 overrides the experiments' threads
  bool resume = false;         ///< continue stored stages; stages already done are replayed
  std::function<void(const StudyProgress&)> on_progress;  ///< may be empty
  const std::atomic<bool>* cancel = nullptr;
};

struct StudySummary {
  RunStatus status = RunStatus::kCompleted;
  double wall_s = 0.0;
  long flights = 0;            ///< tuning and validation flights flown
  long resolves = 0;
};

/// Runs the study (see the file comment). Configuration problems throw ConfigError before any
/// work; failures inside flights are recorded in the stores and in validation.csv.
StudySummary RunStudy(const Study& study, const StudyOptions& options);

}  // namespace quadtune::engine
