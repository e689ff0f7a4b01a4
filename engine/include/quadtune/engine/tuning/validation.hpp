#pragma once
/// \file
/// Held-out validation: parameter sets flown on maps that no trial flew, every set on the same
/// maps with the same flight seeds (common random numbers), so that their f_l compare pairwise.
/// `quadtune run` ends with it (RunExperiment: each trial's recommended point and the defaults
/// on experiment.validation.maps maps, stored as kind 'validation'); `quadtune study` flies
/// every stage's recommended points in the last stage's world.
///
/// The held-out maps are Experiment::HeldOutMapSeed(0 … n−1), derived under a tag that no
/// tuning map uses (Experiment::FlightMapSeed), so they are disjoint from every map of a trial.
///
/// Thread safety: FlyJobs runs the flights on its own oneTBB arena of `threads` threads, one
/// world-pool slot per thread; the planner's members are called concurrently on distinct slots.

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "quadtune/engine/api/planner.hpp"

namespace quadtune::engine {

/// One flight of a parameter set on one map.
struct FlightJob {
  ParamValues params;            ///< merged over the planner's defaults by the planner
  std::uint64_t map_seed = 0;    ///< PrepareMap seed
  std::uint64_t flight_seed = 0; ///< FlightRequest::seed
};

/// Flies every job on `threads` (>= 1) threads; each map is prepared once per seed. Records come
/// back in job order; a job that throws is recorded as kFailed with the exception's text, never
/// rethrown. When `cancel` is set, the jobs not yet started come back as kCancelled.
/// `progress(done, total)` (may be empty) is called after each flight, from worker threads, one
/// call at a time (`done` counts up by one from call to call).
std::vector<FlightRecord> FlyJobs(const Planner& planner, const std::vector<FlightJob>& jobs,
                                  int threads, const std::atomic<bool>* cancel,
                                  const std::function<void(int, int)>& progress);

/// Held-out result of one parameter set (a trial's recommended point, or the defaults).
struct ValidationSummary {
  std::string method;      ///< the trial's method ("default" for the defaults)
  int repeat = 0;          ///< the trial's repeat (-1 for the defaults)
  ParamValues params;
  int flights = 0;         ///< flights that ran (not cancelled)
  double mean_value = 0.0; ///< mean f_l over them (failures count objective.failure_value)
  int completed = 0;       ///< flights that reached every waypoint
  int collision_free = 0;  ///< completed flights without a collision
  int emergency_stops = 0; ///< Σ n_e
};

}  // namespace quadtune::engine
