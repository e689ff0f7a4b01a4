#pragma once
// Helpers shared by the engine tests.
#include <atomic>
#include <filesystem>
#include <string>
#include <vector>

#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/tuner.hpp"

namespace quadtune::engine::test {

/// The toy experiment used by most tests: small and fast (milliseconds per trial).
/// `validation_maps`: held-out validation maps (0: none, so row counts are the trials' only).
inline std::string ToyYaml(const std::string& methods = "[default, random, pso, bo, bo_pso]",
                           const std::string& extra_toy = "", int flights = 6,
                           int validation_maps = 0) {
  return "name: toy-test\nseed: 11\nthreads: 2\nmode: reproducible\nrepeats: 1\n"
         "methods: " + methods + "\n"
         "planner:\n  type: toy\n  toy: {length: 10, gates: 4, plan_interval: 1.0" + extra_toy + "}\n"
         "parameters:\n"
         "  - {name: gain, lower: 0.05, upper: 1.5, default: 0.3}\n"
         "  - {name: max_iter, lower: 2, upper: 40, type: integer, default: 20}\n"
         "  - {name: speed, lower: 0.5, upper: 6.0, default: 2.0}\n"
         "  - {name: margin, lower: 0.0, upper: 3.0, default: 0.5}\n"
         "short_term: [gain, max_iter]\nlong_term: [speed, margin]\n"
         "objective:\n  short_term: {tau_t: 0.002}\n"
         "validation: {maps: " + std::to_string(validation_maps) + "}\n"
         "budget: {flights: " + std::to_string(flights) +
         ", flight_batch: 2, short_evals_per_flight: 4, queries_per_eval: 2, query_window: 50}\n"
         "pso: {num_particles: 4}\n"
         "bo: {initial_design_size: 2, acquisition_pool: 50, acquisition_starts: 1, "
         "hyper_restarts: 0}\n";
}

/// One flight of `planner` with its default parameters on the map of `map_seed` (flight seed 3)
/// in `slot`; every planning query it reports is appended to *queries.
inline FlightRecord FlyRecordingQueries(const Planner& planner, std::uint64_t map_seed,
                                        WorkerSlot& slot, std::vector<Opaque>* queries) {
  FlightRequest req;
  req.map = planner.PrepareMap(map_seed);
  req.params = planner.Defaults();
  req.seed = 3;
  req.on_query = [queries](const Opaque& q) { queries->push_back(q); };
  return planner.Fly(req, slot);
}

/// A fresh temporary directory for one test.
inline std::string TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("quadtune_engine_" + name);
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

/// Evaluations without the wall-clock columns (wall_s, started, finished) and the trial ids,
/// one string per row, every other column of EvaluationColumns(), for exact comparison.
inline std::vector<std::string> Deterministic(const std::string& store_path) {
  ResultStore store(store_path);
  std::vector<std::string> rows;
  for (const auto& r : store.Evaluations()) {
    std::string row;
    for (const auto& c : EvaluationColumns().List()) {
      if (c.name == "wall_s" || c.name == "started" || c.name == "finished" ||
          c.name == "trial_id") {
        continue;
      }
      row += ColumnText(c.get(r), c.type, /*shortest=*/false) + "|";
    }
    rows.push_back(row);
  }
  return rows;
}

/// Runs `e` uncut into DIR/full.sqlite and cut after `cut_after` progress reports into
/// DIR/part.sqlite, then resumes the cut one (`resumed`: the resume's summary).
struct CutAndResumed {
  std::string full, part;
  RunSummary cut, resumed;
  std::vector<std::string> partial;  ///< Deterministic(part) before the resume
};
inline CutAndResumed CutThenResume(const Experiment& e, const std::string& dir, int cut_after) {
  CutAndResumed out;
  out.full = dir + "/full.sqlite";
  out.part = dir + "/part.sqlite";
  RunOptions full;
  full.store_path = out.full;
  (void)RunExperiment(e, full);
  std::atomic<bool> cancel{false};
  RunOptions part;
  part.store_path = out.part;
  part.cancel = &cancel;
  int reports = 0;
  part.on_progress = [&](const Progress&) {
    if (++reports == cut_after) cancel.store(true);
  };
  out.cut = RunExperiment(e, part);
  out.partial = Deterministic(out.part);
  RunOptions resume;
  resume.store_path = out.part;
  resume.resume = true;
  out.resumed = RunExperiment(e, resume);
  return out;
}

}  // namespace quadtune::engine::test
