#include "stored_flight.hpp"

#include <spdlog/spdlog.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>
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

std::string TidyName(const std::string& stored) {
  static const std::map<std::string, std::string> renamed = {
      {"status", ""},
      {"message", "state_reason"},
      {"wall_s", "duration"},
      {"started", "datetime_start"},
      {"finished", "datetime_complete"}};
  const auto it = renamed.find(stored);
  return it == renamed.end() ? stored : it->second;
}

std::string IsoUtc(double unix_s) {
  if (!(unix_s > 0.0)) return "";
  const auto micros = static_cast<std::int64_t>(std::llround(unix_s * 1e6));
  const std::time_t seconds = static_cast<std::time_t>(micros / 1000000);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char text[48];
  std::snprintf(text, sizeof text, "%04d-%02d-%02dT%02d:%02d:%02d.%06dZ", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec,
                static_cast<int>(micros % 1000000));
  return text;
}

namespace {

/// An object key's tidy cell: typed keys (Columns::KeyTypes) as whole numbers or true/false,
/// other numbers in their shortest exact form.
std::string KeyCell(const nlohmann::json& v, const std::string& type) {
  if (v.is_number() && !type.empty()) {
    const double x = v.get<double>();
    if (type == "boolean" && (x == 0.0 || x == 1.0)) return x == 1.0 ? "true" : "false";
    if (type == "integer" && x == std::round(x) && std::abs(x) < 9e15) {
      return std::to_string(static_cast<long long>(x));
    }
  }
  return Number(v);
}

/// The key → "integer"/"boolean" map of an object column (Columns::KeyTypes).
std::map<std::string, std::string> KeyTypesOf(const Columns<engine::EvaluationRow>::Column& c) {
  std::map<std::string, std::string> types;
  for (const auto& n : c.names) {
    const auto colon = n.rfind(':');
    types[n.substr(0, colon)] = n.substr(colon + 1);
  }
  return types;
}

/// The tidy rows of one store, by kind.
struct TidyRows {
  struct Row {
    std::vector<std::string> fixed;       // the tidy fixed columns (TidyColumns)
    std::vector<nlohmann::json> objects;  // the list's JSON objects, in list order
  };
  std::vector<const Columns<engine::EvaluationRow>::Column*> objects;
  std::map<std::string, std::vector<Row>> by_kind;
  /// Per kind, per object column: the keys met, in order.
  std::map<std::string, std::vector<std::vector<std::string>>> keys;
  /// The experiment's integer parameters (`type: integer`), typed "integer" in params_<name>.
  std::map<std::string, std::string> param_types;

  void Add(const std::string& kind, Row r) {
    auto& kind_keys = keys[kind];
    kind_keys.resize(objects.size());
    for (std::size_t k = 0; k < r.objects.size(); ++k) {
      for (auto it = r.objects[k].begin(); it != r.objects[k].end(); ++it) {
        auto& seen = kind_keys[k];
        if (std::find(seen.begin(), seen.end(), it.key()) == seen.end()) seen.push_back(it.key());
      }
    }
    by_kind[kind].push_back(std::move(r));
  }
};

/// name → "integer" for each parameter of an experiment config with `type: integer`; empty when
/// the config is not YAML of that shape.
std::map<std::string, std::string> IntegerParameters(const std::string& config) {
  std::map<std::string, std::string> types;
  try {
    const YAML::Node parameters = YAML::Load(config)["parameters"];
    if (!parameters.IsSequence()) return types;
    for (const auto& p : parameters) {
      if (p.IsMap() && p["name"] && p["type"] && p["type"].as<std::string>() == "integer") {
        types[p["name"].as<std::string>()] = "integer";
      }
    }
  } catch (const YAML::Exception&) {
    types.clear();  // not the YAML an experiment is: no parameter typed
  }
  return types;
}

TidyRows ReadTidyRows(const std::string& store) {
  const ReadOnlyStore db(store);
  TidyRows out;
  for (const auto& c : engine::EvaluationColumns().List()) {
    if (c.type == ColumnType::kObject) out.objects.push_back(&c);
  }
  db.Query("SELECT config FROM experiment ORDER BY id LIMIT 1", [&](sqlite3_stmt* s) {
    out.param_types = IntegerParameters(Text(s, 0));
  });
  std::int64_t number = 0;
  db.Query(
      "SELECT e.id, t.repeat, t.map_seed, " + engine::EvaluationSqlColumns("e.") +
          " FROM evaluation e LEFT JOIN trial t ON t.id = e.trial_id ORDER BY e.id",
      [&](sqlite3_stmt* s) {
        TidyRows::Row r;
        const std::string id = Text(s, 0);
        engine::EvaluationRow row = RowOf(s, 3, store, id);
        if (row.map_seed == 0 && row.kind != engine::EvalKind::kShort) {
          row.map_seed = Seed(Text(s, 2));
        }
        r.fixed = {std::to_string(number++), id, Text(s, 1)};
        for (const auto& c : engine::EvaluationColumns().List()) {
          const ColumnValue v = c.get(row);
          const std::string name = TidyName(c.name);
          if (c.type == ColumnType::kObject) {
            r.objects.push_back(
                StoredObject(store, id, c.name.c_str(), std::get<std::string>(v)));
          } else if (name.rfind("datetime_", 0) == 0) {
            r.fixed.push_back(IsoUtc(std::get<double>(v)));
          } else if (!name.empty()) {
            r.fixed.push_back(engine::ColumnText(v, c.type, /*shortest=*/true));
          }
        }
        out.Add(ToString(row.kind), std::move(r));
      });
  return out;
}

/// Writes one kind's tidy file.
void WriteTidyFile(const TidyRows& rows, const std::string& kind, const std::string& path) {
  std::vector<std::vector<std::string>> keys = rows.keys.count(kind) ? rows.keys.at(kind)
                                                                      : decltype(keys){};
  keys.resize(rows.objects.size());
  std::vector<std::map<std::string, std::string>> types;
  std::ofstream csv(path);
  std::string header;
  for (const auto& c : TidyColumns()) header += (header.empty() ? "" : ",") + c;
  for (std::size_t k = 0; k < rows.objects.size(); ++k) {
    types.push_back(KeyTypesOf(*rows.objects[k]));
    if (rows.objects[k]->name == "params") types.back().insert(rows.param_types.begin(), rows.param_types.end());
    for (const auto& n : keys[k]) {
      header += ',';
      header += Cell(rows.objects[k]->prefix + n);
    }
  }
  csv << header << '\n';
  if (!rows.by_kind.count(kind)) return;
  for (const auto& r : rows.by_kind.at(kind)) {
    for (std::size_t c = 0; c < r.fixed.size(); ++c) csv << (c ? "," : "") << Cell(r.fixed[c]);
    for (std::size_t k = 0; k < rows.objects.size(); ++k) {
      for (const auto& n : keys[k]) {
        const auto type = types[k].find(n);
        csv << ','
            << (r.objects[k].contains(n)
                    ? Cell(KeyCell(r.objects[k][n], type == types[k].end() ? "" : type->second))
                    : std::string());
      }
    }
    csv << '\n';
  }
}

}  // namespace

std::vector<std::string> TidyColumns() {
  std::vector<std::string> names = {"number", "id", "repeat"};
  for (const auto& c : engine::EvaluationColumns().List()) {
    if (c.type != ColumnType::kObject && !TidyName(c.name).empty()) {
      names.push_back(TidyName(c.name));
    }
  }
  return names;
}

const std::vector<std::pair<std::string, std::string>>& TidyFiles() {
  static const std::vector<std::pair<std::string, std::string>> files = {
      {"long", "long_term.csv"},   {"short", "short_term.csv"}, {"validation", "validation.csv"},
      {"recheck", "recheck.csv"}, {"race", "race.csv"},         {"incumbent", "incumbent.csv"}};
  return files;
}

std::vector<std::string> WriteTidyCsv(const std::string& store, const std::string& directory) {
  const TidyRows rows = ReadTidyRows(store);
  std::filesystem::create_directories(directory);
  std::vector<std::string> written;
  for (const auto& [kind, file] : TidyFiles()) {
    if (kind != "long" && kind != "short" && !rows.by_kind.count(kind)) continue;
    WriteTidyFile(rows, kind, (std::filesystem::path(directory) / file).string());
    written.push_back(file);
  }
  return written;
}

}  // namespace quadtune::cli
