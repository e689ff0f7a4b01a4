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
#include <utility>
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

/// The tidy name of stored evaluation column `stored` ("" for `status`, which the tidy tables
/// leave out as `state` tells more): `message` → state_reason, `wall_s` → duration, `started` →
/// datetime_start, `finished` → datetime_complete; any other column keeps its name.
std::string TidyName(const std::string& stored);

/// Unix time `unix_s` as ISO-8601 UTC with microseconds ("2026-12-07T07:11:29.123456Z"); ""
/// for 0 (not recorded).
std::string IsoUtc(double unix_s);

/// The columns every tidy table starts with: number (0-based, the store's evaluation order),
/// id, repeat, then engine::EvaluationColumns() but the JSON objects, under their TidyName.
std::vector<std::string> TidyColumns();

/// The tidy files by kind, in the order written: long → long_term.csv, short → short_term.csv,
/// validation.csv, recheck.csv, race.csv, incumbent.csv.
const std::vector<std::pair<std::string, std::string>>& TidyFiles();

/// Writes the tidy tables of `store` into `directory`: long_term.csv and short_term.csv always,
/// the other TidyFiles() when the store holds such rows; returns the files written. One row per
/// evaluation in the store's evaluation order: TidyColumns(), then `params_<name>` per parameter
/// and `terms_<name>` per objective term (the object column's prefix and key). Timestamps are
/// IsoUtc; the terms' typed keys (engine::EvaluationColumns, Columns::KeyTypes) are written as
/// whole numbers or true/false, every other number in its shortest exact form. Cells absent
/// from a row are empty.
std::vector<std::string> WriteTidyCsv(const std::string& store, const std::string& directory);

}  // namespace quadtune::cli
