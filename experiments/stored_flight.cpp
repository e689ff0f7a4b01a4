#include "stored_flight.hpp"

#include <spdlog/spdlog.h>
#include <sqlite3.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "quadtune/common/error.hpp"
#include "quadtune/engine/store/row_codec.hpp"

namespace quadtune::cli {
namespace {

/// A read-only connection and one prepared statement at a time.
class ReadOnlyStore {
 public:
  explicit ReadOnlyStore(std::string path) : path_(std::move(path)) {
    if (!std::filesystem::is_regular_file(path_)) {
      throw ConfigError(path_, "", "no such results store (a results.sqlite file is expected)");
    }
    if (sqlite3_open_v2(path_.c_str(), &db_, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
      const std::string why = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      throw ConfigError(path_, "", "cannot open the results store: " + why);
    }
  }
  ~ReadOnlyStore() { sqlite3_close(db_); }
  ReadOnlyStore(const ReadOnlyStore&) = delete;
  ReadOnlyStore& operator=(const ReadOnlyStore&) = delete;

  /// Runs `sql` and calls `row` with the statement positioned on each result row.
  template <class RowFn>
  void Query(const std::string& sql, RowFn&& row) const {
    sqlite3_stmt* raw = nullptr;
    if (sqlite3_prepare_v2(db_, sql.c_str(), -1, &raw, nullptr) != SQLITE_OK) {
      throw ConfigError(path_, "",
                        std::string("not a quadtune results store: ") + sqlite3_errmsg(db_));
    }
    std::unique_ptr<sqlite3_stmt, int (*)(sqlite3_stmt*)> stmt(raw, sqlite3_finalize);
    int rc = 0;
    while ((rc = sqlite3_step(raw)) == SQLITE_ROW) row(raw);
    if (rc != SQLITE_DONE) throw ConfigError(path_, "", sqlite3_errmsg(db_));
  }
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  std::string path_;
  sqlite3* db_ = nullptr;
};

std::string Text(sqlite3_stmt* s, int col) {
  const auto* t = sqlite3_column_text(s, col);
  return t ? reinterpret_cast<const char*>(t) : "";
}
std::uint64_t Seed(const std::string& text) { return text.empty() ? 0 : std::stoull(text); }

/// CSV cell: quoted when it holds a separator, quote or line break.
std::string Cell(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string Number(const nlohmann::json& v) {
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  if (v.is_number()) return nlohmann::json(v.get<double>()).dump();
  if (v.is_boolean()) return v.get<bool>() ? "1" : "0";
  return v.is_string() ? v.get<std::string>() : v.dump();
}

/// The JSON object in `column` of evaluation `id` ({} when empty); ConfigError naming the store,
/// the evaluation and the column when it is not one.
nlohmann::json StoredObject(const std::string& store, const std::string& id, const char* column,
                            const std::string& text) {
  if (text.empty()) return nlohmann::json::object();
  nlohmann::json j = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) {
    throw ConfigError(store, std::string("evaluation ") + id + ": " + column,
                      "damaged results store: not a JSON object (" +
                          (text.size() > 40 ? text.substr(0, 40) + "…" : text) + ")");
  }
  return j;
}

/// The evaluation row in `s`'s result columns from `first` on; a value its column cannot hold
/// is a ConfigError naming the store, the evaluation and the column.
engine::EvaluationRow RowOf(sqlite3_stmt* s, int first, const std::string& store,
                            const std::string& id) {
  try {
    return engine::ReadEvaluationRow(s, first);
  } catch (const ColumnError& e) {
    throw ConfigError(store, "evaluation " + id, std::string("damaged results store: ") + e.what());
  }
}

}  // namespace

std::vector<std::int64_t> BestFlightIds(const std::string& store, int limit) {
  const ReadOnlyStore db(store);
  std::vector<std::int64_t> ids;
  std::set<std::string> seen;
  db.Query(
      "SELECT id, method FROM evaluation WHERE kind = 'long' AND status = 'ok' "
      "ORDER BY value, id",
      [&](sqlite3_stmt* s) {
        if (static_cast<int>(ids.size()) >= limit) return;
        if (seen.insert(Text(s, 1)).second) ids.push_back(sqlite3_column_int64(s, 0));
      });
  return ids;
}

engine::Replay FlyStored(const std::string& store, std::int64_t id, const std::string& out) {
  spdlog::info("flying evaluation {} of {} again", id, store);
  engine::Replay replay = engine::FlyStoredAgain(store, id, out);
  const engine::EvaluationRow& row = replay.stored.row;
  const engine::FlightRecord& r = replay.record;
  spdlog::info("{} (map seed {}, flight seed {}): t_f {} s, n_c {}, n_e {}, value {} (stored {}); "
               "wrote {}",
               ToString(row.method), row.map_seed, row.flight_seed, r.flight_time, r.collisions,
               r.emergency_stops, replay.objective.value, row.value, out);
  for (const auto& d : replay.differences) spdlog::error("flown again: {}", d);
  if (!replay.same) spdlog::error("the flight flown again differs from the stored one");
  return replay;
}

void WriteTidyCsv(const std::string& store, const std::string& directory) {
  const ReadOnlyStore db(store);
  const auto& columns = engine::EvaluationColumns().List();
  struct Row {
    std::vector<std::string> fixed;               // id, repeat, then the list's plain columns
    std::vector<nlohmann::json> objects;          // the list's JSON objects, in list order
  };
  std::vector<std::string> fixed = {"id", "repeat"};
  std::vector<const Columns<engine::EvaluationRow>::Column*> objects;
  for (const auto& c : columns) {
    if (c.type == ColumnType::kObject) {
      objects.push_back(&c);
    } else {
      fixed.push_back(c.name);
    }
  }
  std::map<std::string, std::vector<Row>> by_kind;
  // Per kind, per object column: the keys met, in order.
  std::map<std::string, std::vector<std::vector<std::string>>> names;
  db.Query(
      "SELECT e.id, t.repeat, t.map_seed, " + engine::EvaluationSqlColumns("e.") +
          " FROM evaluation e LEFT JOIN trial t ON t.id = e.trial_id"
          " ORDER BY e.kind, e.trial_id, e.iteration, e.idx",
      [&](sqlite3_stmt* s) {
        Row r;
        const std::string id = Text(s, 0);
        engine::EvaluationRow row = RowOf(s, 3, store, id);
        if (row.map_seed == 0 && row.kind != engine::EvalKind::kShort) {
          row.map_seed = Seed(Text(s, 2));
        }
        r.fixed = {id, Text(s, 1)};
        const std::string kind = ToString(row.kind);
        auto& kind_names = names[kind];
        kind_names.resize(objects.size());
        for (const auto& c : columns) {
          const ColumnValue v = c.get(row);
          if (c.type != ColumnType::kObject) {
            r.fixed.push_back(engine::ColumnText(v, c.type, /*shortest=*/true));
            continue;
          }
          const std::size_t k = r.objects.size();
          r.objects.push_back(StoredObject(store, id, c.name.c_str(), std::get<std::string>(v)));
          for (auto it = r.objects[k].begin(); it != r.objects[k].end(); ++it) {
            auto& seen = kind_names[k];
            if (std::find(seen.begin(), seen.end(), it.key()) == seen.end()) {
              seen.push_back(it.key());
            }
          }
        }
        by_kind[kind].push_back(std::move(r));
      });
  std::filesystem::create_directories(directory);
  const std::map<std::string, std::string> files = {
      {"long", "long_term.csv"},   {"short", "short_term.csv"}, {"validation", "validation.csv"},
      {"recheck", "recheck.csv"}, {"race", "race.csv"},         {"incumbent", "incumbent.csv"}};
  for (const auto& [kind, file] : files) {
    if (kind != "long" && kind != "short" && !by_kind.count(kind)) continue;
    auto& kind_names = names[kind];
    kind_names.resize(objects.size());
    std::ofstream csv(std::filesystem::path(directory) / file);
    std::set<std::string> used(fixed.begin(), fixed.end());
    std::string header;
    for (const auto& c : fixed) header += (header.empty() ? "" : ",") + c;
    for (std::size_t k = 0; k < objects.size(); ++k) {
      for (const auto& n : kind_names[k]) {
        const std::string col = used.count(n) ? objects[k]->prefix + n : n;
        used.insert(col);
        header += "," + Cell(col);
      }
    }
    csv << header << '\n';
    for (const auto& r : by_kind[kind]) {
      for (std::size_t c = 0; c < r.fixed.size(); ++c) csv << (c ? "," : "") << Cell(r.fixed[c]);
      for (std::size_t k = 0; k < objects.size(); ++k) {
        for (const auto& n : kind_names[k]) {
          csv << ',' << (r.objects[k].contains(n) ? Cell(Number(r.objects[k][n])) : std::string());
        }
      }
      csv << '\n';
    }
  }
}

}  // namespace quadtune::cli
