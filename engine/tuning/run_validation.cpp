// RunValidation (tuner.hpp): the held-out validation that ends a run, flown with FlyJobs
// (validation.hpp) and stored as kind 'validation' rows.

#include <chrono>
#include <nlohmann/json.hpp>
#include <optional>

#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/experiment/objectives.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "quadtune/engine/tuning/validation.hpp"

namespace quadtune::engine {

namespace {

double Now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string ToJson(const ParamValues& values) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [k, v] : values) j[k] = v;
  return j.dump();
}

/// One parameter set to validate and where its rows go.
struct Subject {
  std::string method;
  int repeat = -1;
  std::int64_t trial_id = 0;
  ParamValues params;
  int reuse = -1;  // >= 0: the rows of that subject (a `default` trial reuses the defaults')
};

// The stored row of one held-out flight of `subject` on map `map`.
EvaluationRow ValidationRow(const Experiment& e, const Subject& subject, int map,
                            const FlightJob& job, const FlightRecord& rec) {
  const ObjectiveValue value = LongTermObjective(rec, e.objective);
  EvaluationRow r;
  r.trial_id = subject.trial_id;
  const std::optional<Method> method = FromString<Method>(subject.method);
  QT_DEMAND(method.has_value(), "validation of an unknown method '" + subject.method + "'");
  r.method = *method;
  r.kind = EvalKind::kValidation;
  r.iteration = map;
  r.index = 0;
  r.params = ToJson(job.params);
  r.terms = ToJson(value.terms);
  r.value = value.value;
  r.status = rec.status;
  r.state = StateOf(rec);
  r.message = rec.message;
  r.wall_s = rec.wall_time;
  r.finished = Now();
  r.started = r.finished - rec.wall_time;
  r.map_seed = job.map_seed;
  r.flight_seed = job.flight_seed;
  return r;
}

// One summary per subject over its `n` held-out rows (a reusing subject reads the rows of the
// subject it reuses).
std::vector<ValidationSummary> Summaries(const std::vector<Subject>& subjects,
                                         const std::vector<EvaluationRow>& rows, int n) {
  std::vector<ValidationSummary> out;
  for (std::size_t s = 0; s < subjects.size(); ++s) {
    const std::size_t from =
        subjects[s].reuse >= 0 ? static_cast<std::size_t>(subjects[s].reuse) : s;
    ValidationSummary v;
    v.method = subjects[s].method;
    v.repeat = subjects[s].repeat;
    v.params = subjects[s].params;
    for (int m = 0; m < n; ++m) {
      const EvaluationRow& r =
          rows[from * static_cast<std::size_t>(n) + static_cast<std::size_t>(m)];
      if (r.status == EvalStatus::kCancelled) continue;
      const auto terms = nlohmann::json::parse(r.terms.empty() ? std::string("{}") : r.terms);
      const bool completed = terms.value("completed", 0.0) > 0.5;
      ++v.flights;
      v.mean_value += r.value;
      v.completed += completed ? 1 : 0;
      v.collision_free += completed && terms.value("n_c", 0.0) == 0.0 ? 1 : 0;
      v.emergency_stops += static_cast<int>(terms.value("n_e", 0.0));
    }
    if (v.flights > 0) v.mean_value /= v.flights;
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace

std::vector<ValidationSummary> RunValidation(const Experiment& e,
                                             const std::vector<TrialSummary>& trials,
                                             const std::vector<std::int64_t>& trial_ids,
                                             EvaluationStore* store, int threads,
                                             const RunOptions& options, long* flown) {
  const int n = e.validation.maps;
  std::vector<Subject> subjects{{"default", -1, 0, e.Defaults(), -1}};
  for (std::size_t t = 0; t < trials.size(); ++t) {
    Subject s{trials[t].method, trials[t].repeat, t < trial_ids.size() ? trial_ids[t] : 0,
              trials[t].recommended, -1};
    if (s.method == ToString(Method::kDefault)) s.reuse = 0;
    subjects.push_back(std::move(s));
  }
  // Every (subject, map) outcome: replayed rows, then the flights still missing.
  std::vector<EvaluationRow> rows(subjects.size() * static_cast<std::size_t>(n));
  std::vector<FlightJob> jobs;
  std::vector<std::size_t> job_slot;
  for (std::size_t s = 0; s < subjects.size(); ++s) {
    if (subjects[s].reuse >= 0) continue;
    for (int v = 0; v < n; ++v) {
      const std::size_t slot = s * static_cast<std::size_t>(n) + static_cast<std::size_t>(v);
      const EvaluationRow* stored =
          store != nullptr ? store->Find(subjects[s].trial_id, EvalKind::kValidation, v, 0)
                           : nullptr;
      if (stored != nullptr) {
        rows[slot] = *stored;
        continue;
      }
      FlightJob job;
      job.params = subjects[s].params;
      job.map_seed = e.HeldOutMapSeed(v);
      job.flight_seed = e.HeldOutFlightSeed(v);
      jobs.push_back(std::move(job));
      job_slot.push_back(slot);
    }
  }
  const int trials_total = static_cast<int>(trials.size());
  const auto started = std::chrono::steady_clock::now();
  const std::vector<FlightRecord> records =
      FlyJobs(e.planner, jobs, threads, options.cancel, [&](int done, int total) {
        if (!options.on_progress) return;
        Progress p;
        p.method = "validation";
        p.flights_done = done;
        p.flights_total = total;
        p.trials_done = trials_total;
        p.trials_total = trials_total;
        p.elapsed_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
        options.on_progress(p);
      });
  if (flown != nullptr) *flown = static_cast<long>(jobs.size());
  if (options.cancel != nullptr && options.cancel->load()) return {};
  for (std::size_t j = 0; j < jobs.size(); ++j) {
    const std::size_t slot = job_slot[j];
    EvaluationRow& r = rows[slot];
    r = ValidationRow(e, subjects[slot / static_cast<std::size_t>(n)],
                      static_cast<int>(slot % static_cast<std::size_t>(n)), jobs[j], records[j]);
    if (store != nullptr) store->Insert(r);
  }
  return Summaries(subjects, rows, n);
}

}  // namespace quadtune::engine
