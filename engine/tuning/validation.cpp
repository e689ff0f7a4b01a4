#include "quadtune/engine/tuning/validation.hpp"

#include <oneapi/tbb/enumerable_thread_specific.h>

#include <map>
#include <mutex>

#include "quadtune/common/parallel_for.hpp"

namespace quadtune::engine {

std::vector<FlightRecord> FlyJobs(const Planner& planner, const std::vector<FlightJob>& jobs,
                                  int threads, const std::atomic<bool>* cancel,
                                  const std::function<void(int, int)>& progress) {
  std::vector<FlightRecord> records(jobs.size());
  // Maps are prepared once per seed, before the flights, so every flight of one map shares it.
  std::map<std::uint64_t, Opaque> maps;
  std::map<std::uint64_t, std::string> map_errors;
  for (const auto& job : jobs) {
    if (maps.count(job.map_seed) || map_errors.count(job.map_seed)) continue;
    try {
      maps.emplace(job.map_seed, planner.PrepareMap(job.map_seed));
    } catch (const std::exception& ex) {
      map_errors.emplace(job.map_seed, std::string("map: ") + ex.what());
    }
  }
  auto cancelled = [cancel] { return cancel != nullptr && cancel->load(); };
  std::mutex progress_mutex;
  int done = 0;  // flights finished, under progress_mutex
  const int total = static_cast<int>(jobs.size());
  tbb::enumerable_thread_specific<WorkerSlot> slots;
  ParallelFor(threads, std::size_t{0}, jobs.size(), [&](std::size_t i) {
    FlightRecord& r = records[i];
    if (cancelled()) {
      r.status = EvalStatus::kCancelled;
      r.message = "cancelled";
      return;
    }
    const FlightJob& job = jobs[i];
    if (auto err = map_errors.find(job.map_seed); err != map_errors.end()) {
      r.status = EvalStatus::kFailed;
      r.message = err->second;
    } else {
      FlightRequest req;
      req.map = maps.at(job.map_seed);
      req.params = job.params;
      req.seed = job.flight_seed;
      if (cancel != nullptr) req.cancelled = [cancel] { return cancel->load(); };
      WorkerSlot& slot = slots.local();
      try {
        r = planner.Fly(req, slot);
      } catch (const std::exception& ex) {
        r = FlightRecord{};
        r.status = EvalStatus::kFailed;
        r.message = std::string("exception: ") + ex.what();
        slot.ResetState();  // the world may be in any state: rebuild it next time
      }
    }
    if (progress) {
      // Serialised: callers update estimators and print lines that are not thread-safe.
      const std::lock_guard<std::mutex> lock(progress_mutex);
      progress(++done, total);
    }
  });
  return records;
}

}  // namespace quadtune::engine
