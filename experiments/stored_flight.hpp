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

#include "quadtune/engine/tuning/replay.hpp"
#include "quadtune/engine/store/result_store.hpp"

namespace quadtune::cli {

/// Ids of the best stored flight (lowest value among status "ok" long-term rows, ties: lowest
/// id) of each method, methods in order of their best value; at most `limit` ids.
std::vector<std::int64_t> BestFlightIds(const std::string& store, int limit);

/// Flies stored evaluation `id` of `store` again (engine::FlyStoredAgain: any planner type
/// registered in this program, through its plug-in) with its log in `out`, and logs how the new
/// flight compares with the stored one. Throws ConfigError as FlyStoredAgain does.
engine::Replay FlyStored(const std::string& store, std::int64_t id, const std::string& out);

/// Writes `directory`/long_term.csv, short_term.csv (and validation.csv, recheck.csv,
/// race.csv, incumbent.csv when the store holds such rows): one row per evaluation with the
/// columns id, repeat, then every column of engine::EvaluationColumns() in list order but the
/// JSON objects (params, terms), which follow as one column per parameter and one per
/// objective term (a name clashing with a fixed column gets the prefix "param_" or "term_").
/// Cells absent from a row are empty.
void WriteTidyCsv(const std::string& store, const std::string& directory);

}  // namespace quadtune::cli
