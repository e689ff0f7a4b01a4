#include "quadtune/engine/store/result_store.hpp"

#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "quadtune/common/error.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/engine/experiment/experiment.hpp"

#ifndef QUADTUNE_VERSION
#define QUADTUNE_VERSION "0.1.0"
#endif

namespace quadtune::engine {
namespace {

/// "sqlite: PATH: what went wrong" for the last error of `db`.
std::string SqliteError(sqlite3* db) {
  const char* file = sqlite3_db_filename(db, "main");
  return std::string("sqlite: ") + (file != nullptr && *file != '\0' ? file : "?") + ": " +
         sqlite3_errmsg(db);
}

/// Throws for the last error `rc` of `db`: a ConfigError naming the file when the file is
/// damaged or not a database (bad input, like any other malformed file), else runtime_error.
[[noreturn]] void ThrowSqliteError(sqlite3* db, int rc) {
  const int primary = rc & 0xff;
  if (primary == SQLITE_CORRUPT || primary == SQLITE_NOTADB) {
    const char* file = sqlite3_db_filename(db, "main");
    throw ConfigError(file != nullptr ? file : "", "",
                      std::string("the results file is damaged (") + sqlite3_errmsg(db) +
                          "); it cannot be read or resumed");
  }
  throw std::runtime_error(SqliteError(db));
}

class Statement {
 public:
  Statement(sqlite3* db, const std::string& sql) {
    if (const int rc = sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt_, nullptr); rc != SQLITE_OK) {
      ThrowSqliteError(db, rc);
    }
  }
  ~Statement() { sqlite3_finalize(stmt_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  void Bind(int i, const std::string& s) {
    sqlite3_bind_text(stmt_, i, s.c_str(), static_cast<int>(s.size()), SQLITE_TRANSIENT);
  }
  void Bind(int i, double v) { sqlite3_bind_double(stmt_, i, v); }
  void Bind(int i, std::int64_t v) { sqlite3_bind_int64(stmt_, i, v); }
  void Bind(int i, int v) { sqlite3_bind_int(stmt_, i, v); }
  bool Step() {
    const int rc = sqlite3_step(stmt_);
    if (rc == SQLITE_ROW) return true;
    if (rc == SQLITE_DONE) return false;
    ThrowSqliteError(sqlite3_db_handle(stmt_), rc);
  }
  std::string Text(int i) {
    const auto* t = sqlite3_column_text(stmt_, i);
    return t ? reinterpret_cast<const char*>(t) : "";
  }
  double Double(int i) { return sqlite3_column_double(stmt_, i); }
  std::int64_t Int(int i) { return sqlite3_column_int64(stmt_, i); }
  [[nodiscard]] sqlite3_stmt* Raw() const { return stmt_; }

 private:
  sqlite3_stmt* stmt_ = nullptr;
};

double Now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

std::string Machine() {
  char host[256] = {0};
  gethostname(host, sizeof(host) - 1);
  return std::string(host) + ", " + std::to_string(std::thread::hardware_concurrency()) + " cores";
}

const char* kSchema = R"(
CREATE TABLE IF NOT EXISTS stored_column(tbl TEXT, position INTEGER, name TEXT, sql TEXT,
  type TEXT, names TEXT, prefix TEXT, meaning TEXT, UNIQUE(tbl, position));
)";

const char* SqlType(ColumnType type) {
  switch (type) {
    case ColumnType::kInteger: return "INTEGER";
    case ColumnType::kReal: return "REAL";
    default: return "TEXT";
  }
}

/// Seeds are stored as decimal text (SQLite integers are signed); "" reads as 0.
std::string SeedText(std::uint64_t seed) { return seed == 0 ? std::string() : std::to_string(seed); }
std::uint64_t SeedOf(const std::string& text, const std::string& column) {
  if (text.empty()) return 0;
  std::size_t used = 0;
  unsigned long long seed = 0;
  try {
    seed = std::stoull(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.front() == '-') {
    throw ColumnError(column + ": '" + text + "' is not a seed (an integer in [0, 2^64))");
  }
  return seed;
}

std::string ColumnTextOf(sqlite3_stmt* s, int i) {
  const auto* t = sqlite3_column_text(s, i);
  return t ? reinterpret_cast<const char*>(t) : "";
}

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) {
    if (c == '"') out += '"';
    out += c;
  }
  return out + "\"";
}

std::string Num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

/// The SQL names of `list` (those named in `only`, when given), comma-separated, each after
/// `prefix`.
template <class T>
std::string SqlNames(const Columns<T>& list, const std::string& prefix = "",
                     const std::vector<std::string>& only = {}) {
  std::string out;
  for (const auto& c : list.List()) {
    if (!only.empty() && std::find(only.begin(), only.end(), c.name) == only.end()) continue;
    out += (out.empty() ? "" : ", ") + prefix + c.sql;
  }
  return out;
}

/// Binds `row`'s columns of `list` (those named in `only`, when given) to `s`'s parameters
/// from `first` on, in list order; returns the next parameter's index.
template <class T>
int BindColumns(sqlite3_stmt* s, int first, const T& row, const Columns<T>& list,
                const std::vector<std::string>& only = {}) {
  int i = first;
  for (const auto& c : list.List()) {
    if (!only.empty() && std::find(only.begin(), only.end(), c.name) == only.end()) continue;
    const ColumnValue v = c.get(row);
    if (c.type == ColumnType::kInteger) {
      sqlite3_bind_int64(s, i, std::get<std::int64_t>(v));
    } else if (c.type == ColumnType::kReal) {
      sqlite3_bind_double(s, i, std::get<double>(v));
    } else {
      const std::string text = ColumnText(v, c.type, /*shortest=*/false);
      sqlite3_bind_text(s, i, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
    }
    ++i;
  }
  return i;
}

/// The record whose `list` columns stand in `s`'s result columns `first`, `first`+1, ...
/// Throws ColumnError naming the column for a value it cannot hold.
template <class T>
T ReadColumns(sqlite3_stmt* s, int first, const Columns<T>& list) {
  T r{};
  int i = first;
  for (const auto& c : list.List()) {
    switch (c.type) {
      case ColumnType::kInteger: c.set(r, ColumnValue(sqlite3_column_int64(s, i))); break;
      case ColumnType::kReal: c.set(r, ColumnValue(sqlite3_column_double(s, i))); break;
      case ColumnType::kSeed: c.set(r, ColumnValue(SeedOf(ColumnTextOf(s, i), c.name))); break;
      case ColumnType::kValues: QT_DEMAND(false, "a stored column holds no map"); break;
      default: c.set(r, ColumnValue(ColumnTextOf(s, i))); break;
    }
    ++i;
  }
  return r;
}

std::string SelectEvaluations() { return "SELECT " + EvaluationSqlColumns() + " FROM evaluation"; }

/// Creates table `table` (id INTEGER PRIMARY KEY, the columns of `list`, `constraint` if any)
/// and its stored_column rows, or, for a store that has the table, checks that its columns are
/// the list's (a store of another quadtune version is refused, naming both column lists).
template <class T>
void EnsureTable(sqlite3* db, const std::string& path, const std::string& table,
                 const Columns<T>& list, const std::string& constraint) {
  std::string stored;
  {
    Statement s(db, "PRAGMA table_info(" + table + ")");
    while (s.Step()) {
      if (s.Text(1) != "id") stored += (stored.empty() ? "" : ", ") + s.Text(1);
    }
  }
  if (!stored.empty() && stored != SqlNames(list)) {
    throw ConfigError(path, "--resume",
                      "the store's " + table + " columns (" + stored + ") are not this " +
                          "quadtune's (" + SqlNames(list) +
                          "); run again with --overwrite to start afresh");
  }
  if (!stored.empty()) return;
  std::string sql = "CREATE TABLE " + table + "(id INTEGER PRIMARY KEY";
  for (const auto& c : list.List()) sql += ", " + c.sql + " " + SqlType(c.type);
  Statement(db, sql + (constraint.empty() ? "" : ", " + constraint) + ")").Step();
  Statement insert(db,
                   "INSERT OR REPLACE INTO stored_column(tbl, position, name, sql, type, names, "
                   "prefix, meaning) VALUES(?, ?, ?, ?, ?, ?, ?, ?)");
  int position = 0;
  for (const auto& c : list.List()) {
    std::string names;
    for (const auto& n : c.names) names += (names.empty() ? "" : ",") + n;
    insert.Bind(1, table);
    insert.Bind(2, ++position);
    insert.Bind(3, c.name);
    insert.Bind(4, c.sql);
    insert.Bind(5, std::string(ToString(c.type)));
    insert.Bind(6, names);
    insert.Bind(7, c.prefix);
    insert.Bind(8, c.meaning);
    insert.Step();
    sqlite3_reset(insert.Raw());
  }
}

}  // namespace

const Columns<EvaluationRow>& EvaluationColumns() {
  using R = EvaluationRow;
  static const Columns<R> columns =
      Columns<R>()
          .Integer("trial_id", &R::trial_id,
                   "the trial's id (trial table); 0 for held-out flights of the defaults")
          .Enum("method", &R::method, "the trial's method")
          .Enum("kind", &R::kind, "what was evaluated")
          .Integer("iteration", &R::iteration,
                   "round (long), PSO generation (short), held-out map (validation), race "
                   "(race, incumbent), candidate rank (recheck)")
          .Integer("index", &R::index, "position inside the iteration")
          .StoredAs("idx")
          .Object("params", &R::params, "params_", "the parameters evaluated, name → value")
          .Object("terms", &R::terms, "terms_", "every objective term, name → value")
          .KeyTypes({"n_c:integer", "n_e:integer", "queries:integer", "plans:integer",
                     "failed_attempts:integer", "fallback_plans:integer", "n_s:integer",
                     "n_d:integer", "race_map:integer", "flight_no:integer", "maps:integer",
                     "incumbent_maps:integer", "completed:boolean", "success:boolean",
                     "challenger:boolean", "accepted:boolean"})
          .Real("value", &R::value, "the objective value told to the optimiser")
          .Enum("status", &R::status,
                "whether the evaluation ran: `failed` raised an error or diverged")
          .Enum("state", &R::state,
                "what became of it: `ok` only for a flight that reached every waypoint without "
                "a collision, or a re-solve that found a trajectory")
          .Text("message", &R::message, "the reason, in words (how a flight ended)")
          .Real("wall_s", &R::wall_s, "wall-clock duration (s)")
          .Real("started", &R::started, "unix time (s)")
          .Real("finished", &R::finished, "unix time (s)")
          .Seed("map_seed", &R::map_seed, "flights: the seed of the map flown")
          .Seed("flight_seed", &R::flight_seed,
                "flights: the seed of the flight's random streams");
  return columns;
}

std::string EvaluationSqlColumns(const std::string& prefix) {
  return SqlNames(EvaluationColumns(), prefix);
}

const Columns<ExperimentRow>& ExperimentColumns() {
  using E = ExperimentRow;
  static const Columns<E> columns =
      Columns<E>()
          .Text("name", &E::name, "the experiment's name")
          .Text("config", &E::config, "the experiment's configuration text")
          .Integer("seed", &E::seed, "the experiment's seed (its 64 bits as a signed integer)")
          .Text("version", &E::version, "quadtune's version")
          .Text("machine", &E::machine, "host name and cores")
          .Integer("threads", &E::threads, "threads per process")
          .Enum("mode", &E::mode, "timing mode")
          .Real("started", &E::started, "unix time (s)");
  return columns;
}

const Columns<TrialRow>& TrialColumns() {
  using T = TrialRow;
  static const Columns<T> columns =
      Columns<T>()
          .Integer("experiment_id", &T::experiment_id, "the experiment's id")
          .Enum("method", &T::method, "the trial's method")
          .Integer("repeat", &T::repeat, "the repeat")
          .Seed("map_seed", &T::map_seed, "the seed of the trial's first map")
          .Enum("status", &T::status, "where the trial stands")
          .Object("best_params", &T::best_params, "best_",
                  "the best flight's parameters, name → value (NULL while running)")
          .Real("best_value", &T::best_value, "the best flight's f_l (NULL while running)")
          .Real("finished", &T::finished, "unix time (s) it finished (NULL while running)");
  return columns;
}

EvaluationRow ReadEvaluationRow(sqlite3_stmt* s, int first) {
  return ReadColumns(s, first, EvaluationColumns());
}

std::string ColumnText(const ColumnValue& value, ColumnType type, bool shortest) {
  switch (type) {
    case ColumnType::kInteger: return std::to_string(std::get<std::int64_t>(value));
    case ColumnType::kReal:
      return shortest ? nlohmann::json(std::get<double>(value)).dump()
                      : Num(std::get<double>(value));
    case ColumnType::kSeed: return SeedText(std::get<std::uint64_t>(value));
    case ColumnType::kValues: QT_DEMAND(false, "a stored column holds no map"); return "";
    default: return std::get<std::string>(value);
  }
}

void ResultStore::Exec(const std::string& sql) const {
  char* err = nullptr;
  if (sqlite3_exec(db_.get(), sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    std::string msg = err ? err : "?";
    sqlite3_free(err);
    const char* file = sqlite3_db_filename(db_.get(), "main");
    throw std::runtime_error("sqlite: " + std::string(file != nullptr ? file : "?") + ": " + msg);
  }
}

ResultStore::ResultStore(const std::string& path, const Experiment& experiment, int threads,
                         bool resume) {
  namespace fs = std::filesystem;
  if (!resume) {
    for (const char* suffix : {"", "-wal", "-shm", "-journal"}) fs::remove(path + suffix);
  } else if (!PathExists(path)) {
    throw ConfigError(path, "--resume", "no results file to resume from");
  }
  if (!fs::path(path).parent_path().empty()) fs::create_directories(fs::path(path).parent_path());
  db_ = Open(path, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  try {
    Exec("PRAGMA journal_mode=WAL; PRAGMA synchronous=NORMAL;");
    if (resume) {
      // A damaged store (truncated, overwritten) is refused before anything is written to it.
      Statement check(db_.get(), "PRAGMA quick_check");
      const std::string verdict = check.Step() ? check.Text(0) : std::string("no answer");
      if (verdict != "ok") throw std::runtime_error("integrity check: " + verdict);
    }
    Exec(kSchema);
    EnsureTable(db_.get(), path, "experiment", ExperimentColumns(), "");
    EnsureTable(db_.get(), path, "trial", TrialColumns(), "UNIQUE(experiment_id, method, repeat)");
    EnsureTable(db_.get(), path, "evaluation", EvaluationColumns(),
                "UNIQUE(trial_id, kind, iteration, idx)");
    {
      Statement s(db_.get(), "SELECT id, config FROM experiment ORDER BY id LIMIT 1");
      if (s.Step()) {
        if (!resume) throw std::runtime_error("results file " + path + " is not empty");
        if (s.Text(1) != experiment.text) {
          throw ConfigError(path, "--resume",
                            "the stored run used another configuration; resume with the same "
                            "experiment file");
        }
        experiment_id_ = s.Int(0);
      }
    }
    if (experiment_id_ == 0) {
      ExperimentRow row;
      row.name = experiment.name;
      row.config = experiment.text;
      row.seed = static_cast<std::int64_t>(experiment.seed);
      row.version = QUADTUNE_VERSION;
      row.machine = Machine();
      row.threads = threads;
      row.mode = experiment.mode;
      row.started = Now();
      std::string marks;
      for (std::size_t i = 0; i < ExperimentColumns().List().size(); ++i) marks += i ? ",?" : "?";
      Statement s(db_.get(), "INSERT INTO experiment(" + SqlNames(ExperimentColumns()) +
                                 ") VALUES(" + marks + ")");
      BindColumns(s.Raw(), 1, row, ExperimentColumns());
      s.Step();
      experiment_id_ = sqlite3_last_insert_rowid(db_.get());
    }
    Statement s(db_.get(), SelectEvaluations());
    while (s.Step()) {
      EvaluationRow r = ReadEvaluationRow(s.Raw(), 0);
      stored_.emplace(std::make_tuple(r.trial_id, r.kind, r.iteration, r.index), std::move(r));
    }
  } catch (const ConfigError&) {
    throw;  // db_ closes the file
  } catch (const std::exception& e) {
    // sqlite errors, and stored text that does not parse (e.g. a seed column).
    if (!resume) throw;
    throw ConfigError(path, "--resume",
                      std::string("not a readable quadtune results store (") + e.what() +
                          "); run again with --overwrite to start afresh");
  }
}

ResultStore::ResultStore(const std::string& path) {
  if (!PathExists(path)) throw ConfigError(path, "", "no such results file");
  db_ = Open(path, SQLITE_OPEN_READONLY);
}

ResultStore::~ResultStore() = default;

void ResultStore::CloseConnection::operator()(sqlite3* db) const { sqlite3_close(db); }

void ResultStore::FinalizeStatement::operator()(sqlite3_stmt* statement) const {
  sqlite3_finalize(statement);
}

std::unique_ptr<sqlite3, ResultStore::CloseConnection> ResultStore::Open(const std::string& path,
                                                                         int flags) {
  sqlite3* raw = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &raw, flags, nullptr);
  // Owned whatever the outcome: SQLite allocates a handle also when the open fails.
  std::unique_ptr<sqlite3, CloseConnection> db(raw);
  if (rc != SQLITE_OK) throw std::runtime_error("sqlite: cannot open " + path);
  sqlite3_busy_timeout(db.get(), 5000);
  return db;
}

std::int64_t ResultStore::Trial(const std::string& method, int repeat, std::uint64_t map_seed) {
  TrialRow t;
  t.experiment_id = experiment_id_;
  const std::optional<Method> m = FromString<Method>(method);
  QT_DEMAND(m.has_value(), "a trial of an unknown method '" + method + "'");
  t.method = *m;
  t.repeat = repeat;
  t.map_seed = map_seed;
  const std::vector<std::string> key = {"experiment_id", "method", "repeat"};
  {
    Statement s(db_.get(), "SELECT id FROM trial WHERE experiment_id=? AND method=? AND repeat=?");
    BindColumns(s.Raw(), 1, t, TrialColumns(), key);
    if (s.Step()) return s.Int(0);
  }
  // The best point and the finish time stay NULL until FinishTrial.
  const std::vector<std::string> created = {"experiment_id", "method", "repeat", "map_seed",
                                            "status"};
  Statement s(db_.get(), "INSERT INTO trial(" + SqlNames(TrialColumns(), "", created) +
                             ") VALUES(?,?,?,?,?)");
  BindColumns(s.Raw(), 1, t, TrialColumns(), created);
  s.Step();
  return sqlite3_last_insert_rowid(db_.get());
}

const EvaluationRow* ResultStore::Find(std::int64_t trial_id, EvalKind kind, int iteration,
                                       int index) const {
  auto it = stored_.find(std::make_tuple(trial_id, kind, iteration, index));
  return it == stored_.end() ? nullptr : &it->second;
}

std::vector<EvaluationRow> ResultStore::StoredRows(std::int64_t trial_id) const {
  std::vector<EvaluationRow> rows;
  for (auto it = stored_.lower_bound(std::make_tuple(trial_id, EvalKind{}, INT_MIN, INT_MIN));
       it != stored_.end() && std::get<0>(it->first) == trial_id; ++it) {
    rows.push_back(it->second);
  }
  return rows;
}

void ResultStore::BindAndStep(const EvaluationRow& r) {
  if (insert_ == nullptr) {
    std::string marks;
    for (std::size_t i = 0; i < EvaluationColumns().List().size(); ++i) marks += i ? ",?" : "?";
    const std::string sql = "INSERT OR IGNORE INTO evaluation(" + EvaluationSqlColumns() +
                            ") VALUES(" + marks + ")";
    sqlite3_stmt* prepared = nullptr;
    const int rc = sqlite3_prepare_v2(db_.get(), sql.c_str(), -1, &prepared, nullptr);
    insert_.reset(prepared);
    if (rc != SQLITE_OK) {
      throw std::runtime_error(std::string("sqlite: ") + sqlite3_errmsg(db_.get()) + " in " + sql);
    }
  }
  BindColumns(insert_.get(), 1, r, EvaluationColumns());
  const int rc = sqlite3_step(insert_.get());
  sqlite3_reset(insert_.get());
  sqlite3_clear_bindings(insert_.get());
  if (rc != SQLITE_DONE) {
    throw std::runtime_error(std::string("sqlite: ") + sqlite3_errmsg(db_.get()));
  }
}

void ResultStore::Insert(const EvaluationRow& r) { InsertBatch(std::span(&r, 1)); }

void ResultStore::InsertBatch(std::span<const EvaluationRow> rows) {
  if (rows.empty()) return;
  Exec("BEGIN");
  try {
    for (const EvaluationRow& r : rows) BindAndStep(r);
    Exec("COMMIT");
  } catch (...) {
    // SQLite may have rolled back already (e.g. on a full disk); the first error is the one to
    // report, so a failed rollback is not.
    if (sqlite3_get_autocommit(db_.get()) == 0) {
      sqlite3_exec(db_.get(), "ROLLBACK", nullptr, nullptr, nullptr);
    }
    throw;
  }
}

void ResultStore::FinishTrial(std::int64_t trial_id, TrialStatus status,
                              const std::string& best_params, double best_value) {
  TrialRow t;
  t.status = status;
  t.best_params = best_params;
  t.best_value = best_value;
  t.finished = Now();
  const std::vector<std::string> set = {"status", "best_params", "best_value", "finished"};
  std::string assignments;
  for (const auto& c : TrialColumns().List()) {
    if (std::find(set.begin(), set.end(), c.name) != set.end()) {
      assignments += (assignments.empty() ? "" : ", ") + c.sql + "=?";
    }
  }
  Statement s(db_.get(), "UPDATE trial SET " + assignments + " WHERE id=?");
  const int next = BindColumns(s.Raw(), 1, t, TrialColumns(), set);
  s.Bind(next, trial_id);
  s.Step();
}

std::vector<EvaluationRow> ResultStore::Evaluations() const {
  std::vector<EvaluationRow> rows;
  Statement s(db_.get(), SelectEvaluations() + " ORDER BY trial_id, kind, iteration, idx");
  while (s.Step()) rows.push_back(ReadEvaluationRow(s.Raw(), 0));
  return rows;
}

ExperimentRow ResultStore::ExperimentInfo() const {
  Statement s(db_.get(), "SELECT id, " + SqlNames(ExperimentColumns()) +
                             " FROM experiment ORDER BY id LIMIT 1");
  if (!s.Step()) return {};
  ExperimentRow row = ReadColumns(s.Raw(), 1, ExperimentColumns());
  row.id = s.Int(0);
  return row;
}

std::vector<TrialRow> ResultStore::Trials() const {
  std::vector<TrialRow> rows;
  Statement s(db_.get(), "SELECT id, " + SqlNames(TrialColumns()) + " FROM trial ORDER BY id");
  while (s.Step()) {
    TrialRow t = ReadColumns(s.Raw(), 1, TrialColumns());
    t.id = s.Int(0);
    rows.push_back(std::move(t));
  }
  return rows;
}

void ResultStore::ExportCsv(const std::string& directory) const {
  namespace fs = std::filesystem;
  // Every row is read before a file is written: a store that cannot be read leaves none.
  std::ostringstream experiment;
  experiment << "id";
  for (const auto& c : ExperimentColumns().List()) {
    if (c.name != "config") experiment << ',' << c.name;  // the text stays in the store
  }
  experiment << '\n';
  if (const ExperimentRow row = ExperimentInfo(); row.id != 0) {
    experiment << row.id;
    for (const auto& c : ExperimentColumns().List()) {
      if (c.name != "config") {
        experiment << ',' << CsvField(ColumnText(c.get(row), c.type, false));
      }
    }
    experiment << '\n';
  }
  std::ostringstream trials;
  trials << "id";
  for (const auto& c : TrialColumns().List()) trials << ',' << c.name;
  trials << '\n';
  for (const auto& t : Trials()) {
    trials << t.id;
    for (const auto& c : TrialColumns().List()) {
      trials << ',' << CsvField(ColumnText(c.get(t), c.type, false));
    }
    trials << '\n';
  }
  std::ostringstream evaluations;
  const auto& columns = EvaluationColumns().List();
  for (std::size_t c = 0; c < columns.size(); ++c) evaluations << (c ? "," : "") << columns[c].name;
  evaluations << '\n';
  for (const auto& r : Evaluations()) {
    for (std::size_t c = 0; c < columns.size(); ++c) {
      evaluations << (c ? "," : "")
                  << CsvField(ColumnText(columns[c].get(r), columns[c].type, false));
    }
    evaluations << '\n';
  }
  fs::create_directories(directory);
  WriteFileAtomically((fs::path(directory) / "experiment.csv").string(), experiment.str());
  WriteFileAtomically((fs::path(directory) / "trials.csv").string(), trials.str());
  WriteFileAtomically((fs::path(directory) / "evaluations.csv").string(), evaluations.str());
}

}  // namespace quadtune::engine
