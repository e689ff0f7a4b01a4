// The stored schema (EvaluationColumns, TrialSummaryColumns): every reader and writer of stored
// rows follows the one column list. For each column, a row that differs from the default row in
// that column only goes through the SQL store, the row codec and the JSON of the distributed
// path and comes back differing in that column only; the evaluation and trial tables, their
// stored_column lists and the CSV export's headers are the lists. (The tidy export and the Python loader are
// checked against the store's list by CliStoredStates in cli_paths_tests.)
#include <gtest/gtest.h>

#include <fstream>
#include <string>
#include <vector>

#include "../sqlite_util.hpp"
#include "quadtune/engine/store/column_json.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/store/row_codec.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "test_util.hpp"

namespace quadtune::engine {
namespace {

using Column = Columns<EvaluationRow>::Column;

/// A value of `c`'s type that no default row holds.
ColumnValue Unusual(const Column& c) {
  switch (c.type) {
    case ColumnType::kInteger: return std::int64_t{7};
    case ColumnType::kReal: return 2.5;
    case ColumnType::kSeed: return std::uint64_t{18446744073709551557ULL};
    case ColumnType::kEnum: return c.names.back();
    case ColumnType::kObject: return std::string("{\"k\":1.5}");
    default: return std::string("text, \"quoted\"");
  }
}

/// One row per column, each differing from the default row in that column only; distinct
/// store keys through `iteration` (unless iteration is the column).
std::vector<EvaluationRow> OneChangePerColumn() {
  std::vector<EvaluationRow> rows;
  int n = 0;
  for (const Column& c : EvaluationColumns().List()) {
    EvaluationRow r;
    r.iteration = 100 + n++;
    c.set(r, Unusual(c));
    rows.push_back(r);
  }
  return rows;
}

/// `got` equals `want` in every column (by the list).
void ExpectSameColumns(const EvaluationRow& want, const EvaluationRow& got, const char* where) {
  for (const Column& c : EvaluationColumns().List()) {
    EXPECT_TRUE(c.get(want) == c.get(got)) << where << ": column " << c.name;
  }
}

TEST(StoredSchema, EveryColumnRoundTripsThroughStoreCodecAndJson) {
  const std::vector<EvaluationRow> rows = OneChangePerColumn();
  const std::string dir = test::TempDir("stored_schema");
  const Experiment e = Experiment::FromString(test::ToyYaml());
  {
    ResultStore store(dir + "/r.sqlite", e, 1, false);
    store.InsertBatch(rows);
  }
  std::vector<EvaluationRow> stored = ResultStore(dir + "/r.sqlite").Evaluations();
  ASSERT_EQ(stored.size(), rows.size());
  RowBatch batch(1);
  for (const auto& r : rows) batch.Add(r);
  std::vector<EvaluationRow> decoded;
  DecodeBatch(batch.Bytes(), decoded);
  ASSERT_EQ(decoded.size(), rows.size());
  for (std::size_t i = 0; i < rows.size(); ++i) {
    SCOPED_TRACE("the row that changes column " + EvaluationColumns().List()[i].name);
    const EvaluationRow& want = rows[i];
    bool found = false;
    for (const auto& s : stored) {
      if (s.trial_id == want.trial_id && s.kind == want.kind && s.iteration == want.iteration &&
          s.index == want.index) {
        ExpectSameColumns(want, s, "store");
        found = true;
      }
    }
    EXPECT_TRUE(found) << "store";
    ExpectSameColumns(want, decoded[i], "codec");
    const nlohmann::json j = ToJson(want, EvaluationColumns(), JsonReals::kBits);
    ExpectSameColumns(want, FromJson(nlohmann::json::parse(j.dump()), EvaluationColumns()),
                      "distributed JSON");
  }
}

TEST(StoredSchema, TablesAndExportsAreTheList) {
  const std::string dir = test::TempDir("stored_schema_tables");
  const Experiment e = Experiment::FromString(test::ToyYaml());
  {
    ResultStore store(dir + "/r.sqlite", e, 1, false);
    store.Insert(EvaluationRow{});
  }
  const auto& list = EvaluationColumns().List();
  const auto table = quadtune::test::Query(dir + "/r.sqlite", "PRAGMA table_info(evaluation)");
  ASSERT_EQ(table.size(), list.size() + 1);  // the id first
  EXPECT_EQ(table[0][1], "id");
  const auto listed = quadtune::test::Query(dir + "/r.sqlite",
                                  "SELECT name, sql, type, names, prefix, meaning FROM "
                                  "stored_column WHERE tbl = 'evaluation' ORDER BY position");
  ASSERT_EQ(listed.size(), list.size());
  std::string header;
  for (std::size_t i = 0; i < list.size(); ++i) {
    SCOPED_TRACE(list[i].name);
    EXPECT_EQ(table[i + 1][1], list[i].sql);
    EXPECT_EQ(listed[i][0], list[i].name);
    EXPECT_EQ(listed[i][1], list[i].sql);
    EXPECT_EQ(listed[i][2], ToString(list[i].type));
    std::string names;
    for (const auto& n : list[i].names) names += (names.empty() ? "" : ",") + n;
    EXPECT_EQ(listed[i][3], names);
    EXPECT_EQ(listed[i][4], list[i].prefix);
    EXPECT_EQ(listed[i][5], list[i].meaning);
    header += (header.empty() ? "" : ",") + list[i].name;
  }
  ResultStore(dir + "/r.sqlite").ExportCsv(dir + "/csv");
  std::ifstream csv(dir + "/csv/evaluations.csv");
  std::string first;
  std::getline(csv, first);
  EXPECT_EQ(first, header);
}

TEST(StoredSchema, TheTrialTableIsItsList) {
  const std::string dir = test::TempDir("stored_schema_trial");
  const Experiment e = Experiment::FromString(test::ToyYaml());
  {
    ResultStore store(dir + "/r.sqlite", e, 1, false);
    const std::int64_t id = store.Trial("bo", 3, 99);
    store.FinishTrial(id, TrialStatus::kDone, "{\"speed\":2.5}", 4.5);
    (void)store.Trial("pso", 1, 7);
  }
  const auto& list = TrialColumns().List();
  const std::string db = dir + "/r.sqlite";
  const auto table = quadtune::test::Query(db, "PRAGMA table_info(trial)");
  const auto listed = quadtune::test::Query(
      db, "SELECT name, sql, type FROM stored_column WHERE tbl = 'trial' ORDER BY position");
  ASSERT_EQ(table.size(), list.size() + 1);
  ASSERT_EQ(listed.size(), list.size());
  std::string header = "id";
  for (std::size_t i = 0; i < list.size(); ++i) {
    EXPECT_EQ(table[i + 1][1], list[i].sql);
    EXPECT_EQ(listed[i][0], list[i].name);
    EXPECT_EQ(listed[i][2], ToString(list[i].type));
    header += "," + list[i].name;
  }
  const std::vector<TrialRow> trials = ResultStore(db).Trials();
  ASSERT_EQ(trials.size(), 2u);
  EXPECT_EQ(trials[0].method, Method::kBo);
  EXPECT_EQ(trials[0].repeat, 3);
  EXPECT_EQ(trials[0].map_seed, 99u);
  EXPECT_EQ(trials[0].status, TrialStatus::kDone);
  EXPECT_EQ(trials[0].best_params, "{\"speed\":2.5}");
  EXPECT_EQ(trials[0].best_value, 4.5);
  EXPECT_GT(trials[0].finished, 0.0);
  EXPECT_EQ(trials[1].status, TrialStatus::kRunning);
  // A running trial has no best point yet: NULL, not a value that looks like one.
  EXPECT_EQ(quadtune::test::Query(db, "SELECT count(*) FROM trial WHERE best_value IS NULL")[0][0],
            "1");
  ResultStore(db).ExportCsv(dir + "/csv");
  std::ifstream csv(dir + "/csv/trials.csv");
  std::string first;
  std::getline(csv, first);
  EXPECT_EQ(first, header);
}

TEST(StoredSchema, TheExperimentTableIsItsList) {
  const std::string dir = test::TempDir("stored_schema_experiment");
  const Experiment e = Experiment::FromString(test::ToyYaml());
  { ResultStore store(dir + "/r.sqlite", e, 3, false); }
  const std::string db = dir + "/r.sqlite";
  const auto& list = ExperimentColumns().List();
  const auto table = quadtune::test::Query(db, "PRAGMA table_info(experiment)");
  const auto listed = quadtune::test::Query(
      db, "SELECT name, sql, type FROM stored_column WHERE tbl = 'experiment' ORDER BY position");
  ASSERT_EQ(table.size(), list.size() + 1);
  ASSERT_EQ(listed.size(), list.size());
  for (std::size_t i = 0; i < list.size(); ++i) {
    EXPECT_EQ(table[i + 1][1], list[i].sql);
    EXPECT_EQ(listed[i][0], list[i].name);
    EXPECT_EQ(listed[i][2], ToString(list[i].type));
  }
  const ExperimentRow row = ResultStore(db).ExperimentInfo();
  EXPECT_EQ(row.id, 1);
  EXPECT_EQ(row.name, e.name);
  EXPECT_EQ(row.config, e.text);
  EXPECT_EQ(static_cast<std::uint64_t>(row.seed), e.seed);
  EXPECT_EQ(row.threads, 3);
  EXPECT_EQ(row.mode, e.mode);
  EXPECT_GT(row.started, 0.0);
}

TEST(StoredSchema, ResumingAStoreWithOtherColumnsNamesBoth) {
  const std::string dir = test::TempDir("stored_schema_other");
  const Experiment e = Experiment::FromString(test::ToyYaml());
  { ResultStore store(dir + "/r.sqlite", e, 1, false); }
  ASSERT_EQ(std::system(("sqlite3 '" + dir + "/r.sqlite' 'ALTER TABLE evaluation DROP COLUMN "
                         "state'").c_str()),
            0);
  try {
    ResultStore store(dir + "/r.sqlite", e, 1, true);
    ADD_FAILURE() << "resumed a store without the state column";
  } catch (const ConfigError& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find("the store's evaluation columns (trial_id, method, kind"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("are not this quadtune's (" + EvaluationSqlColumns() + ")"),
              std::string::npos)
        << what;
  }
}

// docs/data.md's table of the evaluation columns is the list, row for row.
TEST(StoredSchema, DataPageListsEveryColumn) {
  std::ifstream in(std::string(QUADTUNE_SOURCE_DIR) + "/docs/data.md");
  std::vector<std::string> page;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("| `", 0) == 0) page.push_back(line);
  }
  std::vector<std::string> want;
  for (const auto& c : EvaluationColumns().List()) {
    std::string type = ToString(c.type);
    for (std::size_t i = 0; i < c.names.size(); ++i) {
      type += (i == 0 ? ": `" : ", `") + c.names[i] + "`";
    }
    want.push_back("| `" + c.name + "` | " + type + " | " + c.meaning + " |");
  }
  EXPECT_EQ(page, want);
}

TEST(StoredSchema, TrialSummaryJsonCarriesEveryField) {
  TrialSummary s;
  int n = 0;
  for (const auto& c : TrialSummaryColumns().List()) {
    switch (c.type) {
      case ColumnType::kInteger: c.set(s, std::int64_t{++n}); break;
      case ColumnType::kReal: c.set(s, 0.1 * ++n); break;
      case ColumnType::kValues:
        c.set(s, std::map<std::string, double>{{"v_des", 0.1 * ++n}});
        break;
      default: c.set(s, std::string("m") + std::to_string(++n)); break;
    }
  }
  const TrialSummary back = FromJson(
      nlohmann::json::parse(ToJson(s, TrialSummaryColumns(), JsonReals::kBits).dump()),
      TrialSummaryColumns());
  for (const auto& c : TrialSummaryColumns().List()) {
    EXPECT_TRUE(c.get(s) == c.get(back)) << c.name;
  }
  const nlohmann::json plain = ToJson(s, TrialSummaryColumns(), JsonReals::kNumbers);
  EXPECT_EQ(plain["best_value"], s.best_value);
  EXPECT_EQ(plain["best"]["v_des"], s.best.at("v_des"));
}

}  // namespace
}  // namespace quadtune::engine
