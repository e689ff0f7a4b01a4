#pragma once
/// \file
/// The results store: one SQLite file (WAL journal) per run. A single process commits one
/// transaction per evaluation (Insert); rank 0 of a distributed run commits a batch of
/// evaluations per transaction (InsertBatch).
///
/// Tables (docs/data.md lists every column with its meaning):
///   experiment(id, then the columns of ExperimentColumns(): name, config, seed, version,
///     machine, threads, mode, started)
///   trial(id, then the columns of TrialColumns(): experiment_id, method, repeat, map_seed,
///     status, best_params, best_value, finished) — UNIQUE(experiment_id, method, repeat)
///   evaluation(id, then the columns of EvaluationColumns() in list order)
///     — UNIQUE(trial_id, kind, iteration, idx)
///   stored_column(tbl, position, name, sql, type, names, prefix, meaning): the column lists of
///     the experiment, trial and evaluation tables as written, which readers outside C++ (the
///     Python loader) follow
///
/// Resume: Open(resume = true) checks that the stored configuration text equals the experiment's
/// and loads the stored evaluations; the tuner replays them (same order, same values) instead of
/// computing them again, so nothing is lost or duplicated after a kill -9.
///
/// EvaluationStore is what the tuner needs from a store (trial ids, stored rows for replay, new
/// rows, finished trials). ResultStore is the SQLite implementation; a distributed run forwards
/// these calls from ranks ≠ 0 to the ResultStore of rank 0 over MPI (distributed.hpp).
///
/// Room engine/store: its files include engine headers of this room, api and experiment only
/// (scripts/check_rooms.py; docs/design.md, "Architecture").
///
/// Thread safety: one thread at a time (the tuner's driver thread writes). Find() only reads the
/// rows loaded at open time, so it may run beside the other calls.

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include "quadtune/common/columns.hpp"
#include "quadtune/engine/api/planner.hpp"
#include "quadtune/engine/experiment/method.hpp"
#include "quadtune/engine/experiment/objectives.hpp"

struct sqlite3;
struct sqlite3_stmt;

namespace quadtune::engine {

struct Experiment;

/// What an evaluation row holds.
enum class EvalKind {
  kShort,       ///< θ_s candidate scored by re-solves of recorded queries (f_s)
  kLong,        ///< tuning flight (f_l)
  kValidation,  ///< held-out flight of a recommended point (or the defaults)
  kRecheck,     ///< re-flight of a candidate for the recommended point
  kRace,        ///< racing flight
  kIncumbent,   ///< a race's outcome: the incumbent after it
};
constexpr auto EnumNames(EvalKind) {
  return std::array{EnumName{EvalKind::kShort, "short"},
                    EnumName{EvalKind::kLong, "long"},
                    EnumName{EvalKind::kValidation, "validation"},
                    EnumName{EvalKind::kRecheck, "recheck"},
                    EnumName{EvalKind::kRace, "race"},
                    EnumName{EvalKind::kIncumbent, "incumbent"}};
}

/// One stored evaluation; EvaluationColumns() lists its columns.
struct EvaluationRow {
  std::int64_t trial_id = 0;
  Method method = Method::kDefault;
  EvalKind kind = EvalKind::kLong;
  int iteration = 0;           ///< round (long), PSO generation (short), held-out map (validation)
  int index = 0;               ///< position inside the iteration
  std::string params;          ///< JSON object name → value
  std::string terms;           ///< JSON object of objective terms
  double value = 0.0;          ///< objective value told to the optimiser
  EvalStatus status = EvalStatus::kOk;
  EvalState state = EvalState::kOk;  ///< what became of it (StateOf)
  std::string message;         ///< the reason, in words
  double wall_s = 0.0;         ///< wall-clock duration (s)
  double started = 0.0;        ///< unix time (s)
  double finished = 0.0;       ///< unix time (s)
  std::uint64_t map_seed = 0;     ///< flights: seed of the map flown (PrepareMap); else 0
  std::uint64_t flight_seed = 0;  ///< flights: seed of the flight's random streams; else 0
};

/// The one list of the evaluation table's columns (columns.hpp): the SQL table, the row reader
/// and insert, the row codec, the distributed JSON, the CSV and tidy exports and the
/// `stored_column` table the Python loader reads all follow it.
const Columns<EvaluationRow>& EvaluationColumns();
/// The SQL names of EvaluationColumns(), comma-separated, each after `prefix` (e.g. "e.").
[[nodiscard]] std::string EvaluationSqlColumns(const std::string& prefix = "");
/// The row whose EvaluationColumns() stand in `statement`'s result columns `first`, `first`+1,
/// ... in list order. Throws ColumnError naming the column for a value its column cannot hold.
[[nodiscard]] EvaluationRow ReadEvaluationRow(sqlite3_stmt* statement, int first);
/// A column's value as the CSV and tidy exports write it: reals in their shortest exact form
/// when `shortest`, else as %.17g; seeds as decimal text, "" for 0.
[[nodiscard]] std::string ColumnText(const ColumnValue& value, ColumnType type, bool shortest);

/// The run as stored (one row per store).
struct ExperimentRow {
  std::int64_t id = 0;
  std::string name;
  std::string config;       ///< the experiment's configuration text (compared on resume)
  std::int64_t seed = 0;    ///< the experiment's 64-bit seed, its bits as a signed integer
  std::string version;      ///< quadtune's version
  std::string machine;      ///< host name and cores
  int threads = 0;
  TimingMode mode = TimingMode::kReproducible;
  double started = 0.0;     ///< unix time (s)
};

/// The one list of the experiment table's columns, as EvaluationColumns() for evaluations.
const Columns<ExperimentRow>& ExperimentColumns();

/// Where a trial stands.
enum class TrialStatus { kRunning, kDone, kCancelled };
constexpr auto EnumNames(TrialStatus) {
  return std::array{EnumName{TrialStatus::kRunning, "running"},
                    EnumName{TrialStatus::kDone, "done"},
                    EnumName{TrialStatus::kCancelled, "cancelled"}};
}

/// A trial as stored; TrialColumns() lists its columns (all but the id).
struct TrialRow {
  std::int64_t id = 0;
  std::int64_t experiment_id = 0;
  Method method = Method::kDefault;
  int repeat = 0;
  std::uint64_t map_seed = 0;
  TrialStatus status = TrialStatus::kRunning;
  std::string best_params;  ///< JSON object name → value; empty while running
  double best_value = 0.0;
  double finished = 0.0;    ///< unix time (s); 0 while running
};

/// The one list of the trial table's columns, as EvaluationColumns() for evaluations.
const Columns<TrialRow>& TrialColumns();

/// The store interface the tuner writes through. Implementations say their thread safety.
class EvaluationStore {
 public:
  virtual ~EvaluationStore() = default;
  /// The trial's id (created when new).
  virtual std::int64_t Trial(const std::string& method, int repeat, std::uint64_t map_seed) = 0;
  /// A stored evaluation to replay, if any.
  [[nodiscard]] virtual const EvaluationRow* Find(std::int64_t trial_id, EvalKind kind,
                                                  int iteration, int index) const = 0;
  /// Stores one evaluation. Ignores a key already stored.
  virtual void Insert(const EvaluationRow& row) = 0;
  /// Marks a trial finished with its best point.
  virtual void FinishTrial(std::int64_t trial_id, TrialStatus status,
                           const std::string& best_params, double best_value) = 0;
};

/// See the file comment. Non-copyable.
class ResultStore : public EvaluationStore {
 public:
  /// Creates (resume = false: the file must not hold a run yet — it is replaced) or reopens
  /// (resume = true) the store at `path`. Throws ConfigError when resuming a file made by another
  /// configuration, std::runtime_error on SQLite errors.
  ResultStore(const std::string& path, const Experiment& experiment, int threads, bool resume);
  /// Opens an existing file read-only (export, tests).
  explicit ResultStore(const std::string& path);
  ~ResultStore() override;
  ResultStore(const ResultStore&) = delete;
  ResultStore& operator=(const ResultStore&) = delete;

  /// The trial's id (created when new).
  std::int64_t Trial(const std::string& method, int repeat, std::uint64_t map_seed) override;
  /// A stored evaluation, if any.
  [[nodiscard]] const EvaluationRow* Find(std::int64_t trial_id, EvalKind kind, int iteration,
                                          int index) const override;
  /// Stores one evaluation (one transaction): once it returns, the row survives a kill -9 of
  /// the process (WAL journal, synchronous=NORMAL: not a power loss). Ignores a key already
  /// stored.
  void Insert(const EvaluationRow& row) override;
  /// Stores `rows` in one transaction: when it returns every row is stored (as Insert); when it
  /// throws none is. Keys already stored (also twice inside `rows`) keep their first row.
  void InsertBatch(std::span<const EvaluationRow> rows);
  /// Marks a trial finished with its best point.
  void FinishTrial(std::int64_t trial_id, TrialStatus status, const std::string& best_params,
                   double best_value) override;
  /// The rows of one trial loaded for resume (what Find() can return for it), in key order.
  [[nodiscard]] std::vector<EvaluationRow> StoredRows(std::int64_t trial_id) const;

  /// Every evaluation, ordered by trial, kind, iteration, index.
  [[nodiscard]] std::vector<EvaluationRow> Evaluations() const;
  [[nodiscard]] std::vector<TrialRow> Trials() const;
  /// The experiment row (an empty one when the store holds none).
  [[nodiscard]] ExperimentRow ExperimentInfo() const;
  /// Writes experiment.csv, trials.csv and evaluations.csv into `directory` (created), each
  /// atomically and only once every row was read (a damaged store leaves no file).
  void ExportCsv(const std::string& directory) const;
  /// Number of evaluations loaded from the file when it was opened for resume.
  [[nodiscard]] std::size_t Replayable() const { return stored_.size(); }

 private:
  void Exec(const std::string& sql) const;
  /// Binds `row` to the prepared insert statement and runs it (inside a transaction).
  void BindAndStep(const EvaluationRow& row);
  /// Deleters: sqlite3_close of a connection, sqlite3_finalize of a statement.
  struct CloseConnection {
    void operator()(sqlite3* db) const;
  };
  struct FinalizeStatement {
    void operator()(sqlite3_stmt* statement) const;
  };
  /// Opens the file at `path` with sqlite3_open_v2 `flags` (busy timeout 5 s); throws when it
  /// cannot.
  static std::unique_ptr<sqlite3, CloseConnection> Open(const std::string& path, int flags);
  // Declared in this order, so the statement is finalised before the connection closes.
  std::unique_ptr<sqlite3, CloseConnection> db_;
  std::unique_ptr<sqlite3_stmt, FinalizeStatement> insert_;  // prepared on first use
  std::int64_t experiment_id_ = 0;
  std::map<std::tuple<std::int64_t, EvalKind, int, int>, EvaluationRow> stored_;
};

}  // namespace quadtune::engine
