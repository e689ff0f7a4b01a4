#pragma once
/// \file
/// Reading flights back out of a results store (results.sqlite, schema in
/// quadtune/engine/store/result_store.hpp): one stored long-term row by its id, the best flight of
/// each method, flying a stored flight again with full logs, and the tidy (one row per
/// evaluation, one column per parameter and objective term) CSV export.
///
/// Every function opens the store read-only and closes it before returning. Errors about the
/// store or the asked row are ConfigErrors naming the file, the key and what is allowed.
/// Thread safety: none shared; each call is independent.

#include <cstdint>
#include <string>
#include <vector>

#include "quadtune/engine/store/result_store.hpp"

namespace quadtune::cli {

/// One stored evaluation with what is needed to fly it again.
struct StoredFlight {
  std::int64_t id = 0;       ///< evaluation.id
  engine::EvaluationRow row;  ///< its map_seed: the row's, the trial's when the row has none
  std::string config;        ///< the experiment's configuration text
};

/// The flight stored as evaluation `id` in `store`. Throws ConfigError when the file is not a
/// store, the id is absent, or the row is a short-term (re-solve) evaluation.
StoredFlight LoadStoredFlight(const std::string& store, std::int64_t id);

/// Ids of the best stored flight (lowest value among status "ok" long-term rows, ties: lowest
/// id) of each method, methods in order of their best value; at most `limit` ids.
std::vector<std::int64_t> BestFlightIds(const std::string& store, int limit);

/// Flies stored evaluation `id` again exactly as the tuner flew it (same experiment planner
/// options, map from the map seed, world seed = flight seed, parameters of the row) and writes
/// the flight logs into `out` (flight.csv, plans.csv, plan_steps.csv, obstacles.json,
/// summary.json with the stored row's method, id and terms added, layout.yaml). Returns 0 when
/// the flight's t_f, n_c and n_e equal the stored terms, 4 when they differ (logged).
/// Throws ConfigError for stores whose planner is not the Ipopt planner.
int FlyStored(const std::string& store, std::int64_t id, const std::string& out);

/// Writes `directory`/long_term.csv, short_term.csv (and validation.csv, recheck.csv,
/// race.csv, incumbent.csv when the store holds such rows): one row per evaluation with the
/// columns id, repeat, then every column of engine::EvaluationColumns() in list order but the
/// JSON objects (params, terms), which follow as one column per parameter and one per
/// objective term (a name clashing with a fixed column gets the prefix "param_" or "term_").
/// Cells absent from a row are empty.
void WriteTidyCsv(const std::string& store, const std::string& directory);

}  // namespace quadtune::cli
