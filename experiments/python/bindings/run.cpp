// _core.run: runs or resumes an experiment with the engine (engine::RunExperiment, as `quadtune
// run` does) with the GIL released; progress goes to a Python callable, called with the GIL on
// the thread that drives the run, after every round.
#include <pybind11/stl.h>

#include <atomic>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "bindings.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/store/column_json.hpp"
#include "quadtune/engine/tuning/summary_json.hpp"
#include "quadtune/engine/tuning/tuner.hpp"

namespace quadtune::python {

namespace py = pybind11;

namespace {

/// The run in progress (one at a time in a process): its stop flag and the first failure of a
/// Python planner.
struct ActiveRun {
  std::mutex run_mutex;  // held for the whole run
  std::atomic<bool> cancel{false};
  std::mutex failure_mutex;
  std::optional<std::string> planner_failure;
};

ActiveRun& Active() {
  static auto* run = new ActiveRun;  // never destroyed: worker threads may outlive exit handlers
  return *run;
}


/// The progress callback of RunOptions: calls `progress` (may be None) with a dict under the
/// GIL; a Python exception in it (KeyboardInterrupt included) stops the run and is kept in
/// `error` to be raised when the run has stopped.
/// The callback holds `progress` without a reference (the caller's keeps it alive), so copies of
/// it made without the GIL touch no reference count.
std::function<void(const engine::Progress&)> ProgressCallback(
    py::handle progress, std::optional<py::error_already_set>* error) {
  return [progress, error](const engine::Progress& p) {
    const py::gil_scoped_acquire gil;
    if (error->has_value()) return;
    try {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
      if (progress.is_none()) return;
      progress(py::dict(
          py::arg("method") = p.method, py::arg("repeat") = p.repeat,
          py::arg("flights_done") = p.flights_done, py::arg("flights_total") = p.flights_total,
          py::arg("trials_done") = p.trials_done, py::arg("trials_total") = p.trials_total,
          py::arg("short_evals") = p.short_evals, py::arg("best_long") = p.best_long,
          py::arg("elapsed_s") = p.elapsed_s));
    } catch (py::error_already_set& e) {
      error->emplace(std::move(e));
      Active().cancel = true;
    }
  };
}

/// Loads the experiment (`is_file`: `source` is its path; else its text, named `origin` in errors,
/// relative paths resolved against `base_dir`) and runs it into `store`; returns the summary as
/// JSON text.
std::string Run(const std::string& source, bool is_file, const std::string& origin,
                const std::string& base_dir, const std::string& store, bool resume, int threads,
                const py::object& progress) {
  ActiveRun& active = Active();
  std::optional<py::error_already_set> error;
  std::string summary;
  {
    const py::gil_scoped_release release;
    const std::lock_guard lock(active.run_mutex);
    active.cancel = false;
    active.planner_failure.reset();
    const engine::Experiment experiment =
        is_file ? engine::Experiment::LoadFile(source)
                : engine::Experiment::FromString(source, origin, base_dir);
    engine::RunOptions options;
    options.store_path = store;
    options.threads = threads;
    options.resume = resume;
    options.cancel = &active.cancel;
    options.on_progress = ProgressCallback(progress, &error);
    const engine::RunSummary s = engine::RunExperiment(experiment, options);
    summary = engine::SummaryJson(s, experiment.budget.queries_per_eval).dump();
  }
  if (error) throw std::move(*error);
  const std::lock_guard lock(active.failure_mutex);
  if (active.planner_failure) throw std::runtime_error(*active.planner_failure);
  return summary;
}

}  // namespace

void ReportPlannerFailure(const std::string& message) {
  ActiveRun& active = Active();
  {
    const std::lock_guard lock(active.failure_mutex);
    if (!active.planner_failure) active.planner_failure = message;
  }
  active.cancel = true;
}

void BindRun(py::module_& m) {
  m.def("run", &Run, py::arg("source"), py::arg("is_file"), py::arg("origin"), py::arg("base_dir"),
        py::arg("store"), py::arg("resume"), py::arg("threads"), py::arg("progress"),
        "Runs (or resumes) an experiment into the SQLite store `store` with the GIL released; "
        "returns the summary as JSON text. quadtune.run wraps it.");
}

}  // namespace quadtune::python
