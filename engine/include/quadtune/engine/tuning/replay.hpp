#pragma once
/// \file
/// Flights flown for their full log through the plug-in interface, with any registered planner:
/// a new flight (`quadtune fly`) and a stored flight flown again (`quadtune fly --from`,
/// `quadtune report`). Both fly the planner's Fly() through FlyOnPool, as the tuner does, with
/// FlightRequest::log_directory set, and write the folder's summary.json once, from the outcome.
///
/// Errors about the store or the asked row are ConfigErrors naming the file, the key and what is
/// allowed. Thread safety: nothing shared; each call opens the store read-only and flies on a
/// world pool of its own.

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "quadtune/engine/experiment/objectives.hpp"
#include "quadtune/engine/api/planner.hpp"
#include "quadtune/engine/store/result_store.hpp"

namespace quadtune::engine {

/// One stored long-term evaluation with what is needed to fly it again.
struct StoredFlight {
  std::int64_t id = 0;        ///< evaluation.id
  EvaluationRow row;          ///< its map_seed: the row's, the trial's when the row has none
  std::string config;         ///< the experiment's configuration text
};

/// The flight stored as evaluation `id` in `store`. Throws ConfigError when the file is not a
/// store, the id is absent, or the row is a short-term (re-solve) evaluation.
[[nodiscard]] StoredFlight LoadStoredFlight(const std::string& store, std::int64_t id);

/// Flies `request` with `planner` as the tuner does (FlyOnPool on a world pool of its own) with
/// its full log in `directory` (created): the planner's own log files (FlightRequest::
/// log_directory) and summary.json, an object of
/// - the record's status (the EvalStatus word), message, flight_time, collisions,
///   emergency_stops, plans, failed_plans, failed_attempts, fallback_plans, compute_units,
///   jerk_integral, min_clearance and wall_time;
/// - the planner's facts (FlightRecord::log), in place of same-named ones;
/// - `params`: the parameters flown (the planner's defaults, then request.params);
/// - the keys of `extra` (an object).
/// A cancelled flight writes nothing (a folder made for it is removed again when it is empty).
/// Returns the record.
FlightRecord FlyWithLog(const Planner& planner, FlightRequest request,
                        const std::string& directory,
                        const nlohmann::json& extra = nlohmann::json::object());

/// A stored flight flown again.
struct Replay {
  StoredFlight stored;
  FlightRecord record;
  ObjectiveValue objective;  ///< the new flight's f_l and terms (the stored experiment's weights)
  /// Every long-term term of the new flight (LongTermObjective, but `queries`, which counts what
  /// the tuner recorded) and its value equal the stored ones.
  bool same = false;
  std::vector<std::string> differences;  ///< "t_f 12.5 (stored 12.4)", one per differing value
};

/// Flies stored evaluation `id` of `store` again exactly as the tuner flew it: the planner that
/// the stored configuration builds (any planner type registered in this program), the map of
/// the row's map seed (PrepareMap), the row's parameters and its flight seed. Writes the log as
/// FlyWithLog does, with `stored` in summary.json: the row's store, evaluation, method, kind,
/// iteration, index, value, state, terms, params, map_seed and flight_seed (seeds as text).
/// Throws ConfigError as LoadStoredFlight does, and for a configuration that no longer loads
/// (e.g. a planner type this program has not registered).
[[nodiscard]] Replay FlyStoredAgain(const std::string& store, std::int64_t id,
                                    const std::string& directory);

}  // namespace quadtune::engine
