#include "quadtune/engine/tuning/replay.hpp"

#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <system_error>
#include <type_traits>
#include <utility>
#include <variant>

#include "quadtune/common/error.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/experiment/objectives.hpp"
#include "quadtune/engine/store/row_codec.hpp"
#include "quadtune/engine/tuning/scheduler.hpp"

namespace quadtune::engine {
namespace {

using Json = nlohmann::json;

std::string Text(sqlite3_stmt* s, int col) {
  const auto* t = sqlite3_column_text(s, col);
  return t ? reinterpret_cast<const char*>(t) : "";
}

/// The row of evaluation `id` in `store` (read-only); false when there is none.
bool ReadStoredRow(const std::string& store, std::int64_t id, StoredFlight& f) {
  if (!std::filesystem::is_regular_file(store)) {
    throw ConfigError(store, "", "no such results store (a results.sqlite file is expected)");
  }
  sqlite3* raw_db = nullptr;
  const int opened = sqlite3_open_v2(store.c_str(), &raw_db, SQLITE_OPEN_READONLY, nullptr);
  const std::unique_ptr<sqlite3, int (*)(sqlite3*)> db(raw_db, sqlite3_close);
  if (opened != SQLITE_OK) {
    throw ConfigError(store, "", std::string("cannot open the results store: ") +
                                     (raw_db ? sqlite3_errmsg(raw_db) : "out of memory"));
  }
  const std::string sql =
      "SELECT e.id, t.map_seed, (SELECT config FROM experiment ORDER BY id LIMIT 1), " +
      EvaluationSqlColumns("e.") +
      " FROM evaluation e LEFT JOIN trial t ON t.id = e.trial_id WHERE e.id = " +
      std::to_string(id);
  sqlite3_stmt* raw = nullptr;
  if (sqlite3_prepare_v2(db.get(), sql.c_str(), -1, &raw, nullptr) != SQLITE_OK) {
    throw ConfigError(store, "",
                      std::string("not a quadtune results store: ") + sqlite3_errmsg(db.get()));
  }
  const std::unique_ptr<sqlite3_stmt, int (*)(sqlite3_stmt*)> stmt(raw, sqlite3_finalize);
  const int rc = sqlite3_step(raw);
  if (rc == SQLITE_DONE) return false;
  if (rc != SQLITE_ROW) throw ConfigError(store, "", sqlite3_errmsg(db.get()));
  f.id = sqlite3_column_int64(raw, 0);
  try {
    f.row = ReadEvaluationRow(raw, 3);
  } catch (const ColumnError& e) {
    throw ConfigError(store, "evaluation " + std::to_string(f.id),
                      std::string("damaged results store: ") + e.what());
  }
  const std::string trial_seed = Text(raw, 1);
  if (f.row.map_seed == 0 && !trial_seed.empty()) f.row.map_seed = std::stoull(trial_seed);
  f.config = Text(raw, 2);
  return true;
}

/// The JSON object in `column` of the stored flight ({} when empty); ConfigError naming the
/// store, the evaluation and the column when it is not one.
Json StoredObject(const std::string& store, const StoredFlight& f, const char* column,
                  const std::string& text) {
  if (text.empty()) return Json::object();
  Json j = Json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) {
    throw ConfigError(store, "evaluation " + std::to_string(f.id) + ": " + column,
                      "damaged results store: not a JSON object (" +
                          (text.size() > 40 ? text.substr(0, 40) + "…" : text) + ")");
  }
  return j;
}

Json FactJson(const LogFact& fact) {
  return std::visit([](const auto& v) { return Json(v); }, fact);
}

/// summary.json of a flight (FlyWithLog).
Json Summary(const FlightRecord& r, const ParamValues& params, const Json& extra) {
  Json j = {{"status", ToString(r.status)},
            {"message", r.message},
            {"flight_time", r.flight_time},
            {"collisions", r.collisions},
            {"emergency_stops", r.emergency_stops},
            {"plans", r.plans},
            {"failed_plans", r.failed_plans},
            {"failed_attempts", r.failed_attempts},
            {"fallback_plans", r.fallback_plans},
            {"compute_units", r.compute_units},
            {"jerk_integral", r.jerk_integral},
            {"min_clearance", r.min_clearance},
            {"wall_time", r.wall_time}};
  for (const auto& [name, fact] : r.log) j[name] = FactJson(fact);
  j["params"] = params;
  for (auto it = extra.begin(); it != extra.end(); ++it) j[it.key()] = it.value();
  return j;
}

/// Compares the new flight's objective with the stored row (Replay::same, differences).
void Compare(const ObjectiveValue& now, const EvaluationRow& row, const Json& stored_terms,
             Replay& out) {
  const auto differ = [&out](const std::string& name, double value, const std::string& stored) {
    out.differences.push_back(name + " " + Json(value).dump() + " (stored " + stored + ")");
  };
  for (const auto& [name, value] : now.terms) {
    if (name == "queries") continue;
    const auto it = stored_terms.find(name);
    if (it == stored_terms.end() || !it->is_number()) {
      differ(name, value, "none");
    } else if (it->get<double>() != value) {
      differ(name, value, it->dump());
    }
  }
  if (now.value != row.value) differ("value", now.value, Json(row.value).dump());
  out.same = out.differences.empty();
}

}  // namespace

StoredFlight LoadStoredFlight(const std::string& store, std::int64_t id) {
  StoredFlight f;
  if (!ReadStoredRow(store, id, f)) {
    throw ConfigError(store, "--evaluation",
                      "no evaluation with id " + std::to_string(id) +
                          " (ids are the evaluation table's id column; see `quadtune export "
                          "--tidy`)");
  }
  if (f.row.kind == EvalKind::kShort) {
    throw ConfigError(store, "--evaluation",
                      "evaluation " + std::to_string(id) +
                          " is a short-term re-solve, not a flight; give a long-term row");
  }
  return f;
}

FlightRecord FlyWithLog(const Planner& planner, FlightRequest request,
                        const std::string& directory, const nlohmann::json& extra) {
  const bool existed = std::filesystem::exists(directory);
  std::filesystem::create_directories(directory);
  request.log_directory = directory;
  ParamValues params = planner.Defaults();
  for (const auto& [name, value] : request.params) params[name] = value;
  WorldPool pool;
  const FlightRecord record = FlyOnPool(planner, pool, request);
  if (record.status == EvalStatus::kCancelled) {
    std::error_code ignored;  // a folder made here for nothing goes again (only when empty)
    if (!existed) std::filesystem::remove(directory, ignored);
    return record;
  }
  std::ofstream(std::filesystem::path(directory) / "summary.json")
      << Summary(record, params, extra).dump(1) << '\n';
  return record;
}

Replay FlyStoredAgain(const std::string& store, std::int64_t id, const std::string& directory) {
  Replay out;
  out.stored = LoadStoredFlight(store, id);
  const StoredFlight& f = out.stored;
  const Experiment e = Experiment::FromString(f.config, store + " (stored configuration)");
  const Json params = StoredObject(store, f, "params", f.row.params);
  const Json terms = StoredObject(store, f, "terms", f.row.terms);
  FlightRequest request;
  request.map = e.planner.PrepareMap(f.row.map_seed);
  for (auto it = params.begin(); it != params.end(); ++it) {
    request.params[it.key()] = it.value().get<double>();
  }
  request.seed = f.row.flight_seed;
  const Json stored = {{"store", store},
                       {"evaluation", f.id},
                       {"method", ToString(f.row.method)},
                       {"kind", ToString(f.row.kind)},
                       {"iteration", f.row.iteration},
                       {"index", f.row.index},
                       {"value", f.row.value},
                       {"state", ToString(f.row.state)},
                       {"terms", terms},
                       {"params", params},
                       {"map_seed", std::to_string(f.row.map_seed)},
                       {"flight_seed", std::to_string(f.row.flight_seed)}};
  out.record = FlyWithLog(e.planner, std::move(request), directory, {{"stored", stored}});
  out.objective = LongTermObjective(out.record, e.objective);
  Compare(out.objective, f.row, terms, out);
  return out;
}

}  // namespace quadtune::engine
