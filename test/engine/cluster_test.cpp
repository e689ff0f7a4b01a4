// The pieces of a distributed run that need no MPI: the binary row codec, the store's batch
// commit and the sleep planner (the scale model). The MPI runs themselves are in test/mpi.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "../config_error_util.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/store/row_codec.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "test_util.hpp"
#include "toy_planners.hpp"

namespace quadtune::engine {
namespace {

using quadtune::test::ThrowsConfigError;

/// Rows whose every field differs, with doubles a text encoding would round or lose.
std::vector<EvaluationRow> AwkwardRows() {
  std::vector<EvaluationRow> rows;
  const double values[] = {0.1 + 0.2,
                           -0.0,
                           std::numeric_limits<double>::denorm_min(),
                           std::numeric_limits<double>::infinity(),
                           std::bit_cast<double>(0x7ff8000000000123ULL),  // NaN with a payload
                           -1e308};
  int i = 0;
  for (const double v : values) {
    EvaluationRow r;
    r.trial_id = (std::int64_t{1} << 40) + i;
    r.method = i % 2 == 0 ? Method::kBoPso : Method::kDefault;
    r.kind = i % 3 == 0 ? EvalKind::kLong : EvalKind::kShort;
    r.iteration = -i;
    r.index = 1000 * i;
    r.params = "{\"gain\":0.30000000000000004,\"x\":\"ü\\u0000\"}";
    r.terms = std::string("{\"a\":1}\0tail", 12);  // an embedded NUL byte
    r.value = v;
    r.status = i % 2 == 0 ? EvalStatus::kOk : EvalStatus::kFailed;
    r.state = i % 2 == 0 ? EvalState::kCollision : EvalState::kDiverged;
    r.message = std::string(70000, static_cast<char>('a' + i));  // longer than 16 bits of length
    r.wall_s = v * 0.5;
    r.started = 1.7e9 + i / 3.0;
    r.finished = r.started + 1e-9;
    r.map_seed = 0xffffffffffffffffULL - static_cast<std::uint64_t>(i);
    r.flight_seed = i == 0 ? 0 : (std::uint64_t{1} << 63) + static_cast<std::uint64_t>(i);
    rows.push_back(r);
    ++i;
  }
  return rows;
}

/// Every column of the list equal, reals bit for bit.
void ExpectSameBits(const EvaluationRow& a, const EvaluationRow& b) {
  for (const auto& c : EvaluationColumns().List()) {
    const ColumnValue x = c.get(a);
    const ColumnValue y = c.get(b);
    if (c.type == ColumnType::kReal) {
      EXPECT_EQ(std::bit_cast<std::uint64_t>(std::get<double>(x)),
                std::bit_cast<std::uint64_t>(std::get<double>(y)))
          << c.name;
    } else {
      EXPECT_TRUE(x == y) << c.name;
    }
  }
}

TEST(RowCodec, BatchRoundTripsEveryFieldBitForBit) {
  const auto rows = AwkwardRows();
  RowBatch batch(77);
  for (const auto& r : rows) batch.Add(r);
  EXPECT_EQ(batch.Rows(), rows.size());
  std::vector<EvaluationRow> decoded{EvaluationRow{}};  // decoding appends
  EXPECT_EQ(DecodeBatch(batch.Bytes(), decoded), 77u);
  ASSERT_EQ(decoded.size(), rows.size() + 1);
  for (std::size_t i = 0; i < rows.size(); ++i) ExpectSameBits(rows[i], decoded[i + 1]);
  // An empty batch is a valid message.
  RowBatch empty(3);
  std::vector<EvaluationRow> none;
  EXPECT_EQ(DecodeBatch(empty.Bytes(), none), 3u);
  EXPECT_TRUE(none.empty());
}

TEST(RowCodec, MalformedBytesAreRejected) {
  RowBatch batch(1);
  batch.Add(AwkwardRows()[1]);
  const std::string bytes = batch.Bytes();
  std::vector<EvaluationRow> rows;
  EXPECT_THROW(DecodeBatch(bytes.substr(0, bytes.size() - 1), rows), CodecError);
  EXPECT_THROW(DecodeBatch(bytes + "x", rows), CodecError);
  EXPECT_THROW(DecodeBatch("{\"type\":\"bye\"}", rows), CodecError);
  EXPECT_THROW(DecodeBatch("", rows), CodecError);
}

TEST(ResultStoreBatch, OneTransactionStoresEveryRowOnceAndReadsBackExactly) {
  const std::string dir = test::TempDir("insert_batch");
  const Experiment e = Experiment::FromString(test::ToyYaml());
  auto rows = AwkwardRows();
  // SQLite's REAL keeps neither NaN (it becomes NULL) nor the sign of zero: not the codec's.
  for (auto& r : rows) {
    if (std::isnan(r.value) || r.value == 0.0) r.value = 1.5;
  }
  std::vector<EvaluationRow> batch = rows;
  EvaluationRow again = rows[2];
  again.value = 42.0;  // the same key twice: the first row stays
  batch.push_back(again);
  {
    ResultStore store(dir + "/r.sqlite", e, 1, false);
    store.InsertBatch(batch);
    store.InsertBatch(std::vector<EvaluationRow>{});
    store.Insert(again);
  }
  ResultStore read(dir + "/r.sqlite");
  const auto stored = read.Evaluations();
  ASSERT_EQ(stored.size(), rows.size());
  for (const auto& s : stored) {
    bool found = false;
    for (const auto& r : rows) {
      if (r.trial_id != s.trial_id) continue;
      found = true;
      EXPECT_EQ(s.params, r.params);
      EXPECT_EQ(s.map_seed, r.map_seed);
      EXPECT_EQ(s.flight_seed, r.flight_seed);
      EXPECT_EQ(std::bit_cast<std::uint64_t>(s.value), std::bit_cast<std::uint64_t>(r.value));
    }
    EXPECT_TRUE(found);
  }
}

TEST(ResultStoreBatch, AFailingRowRollsBackTheWholeBatch) {
  const std::string dir = test::TempDir("insert_batch_rollback");
  const Experiment e = Experiment::FromString(test::ToyYaml());
  const std::string path = dir + "/r.sqlite";
  std::vector<EvaluationRow> rows = AwkwardRows();
  {
    ResultStore store(path, e, 1, false);
    store.InsertBatch(std::vector<EvaluationRow>(rows.begin(), rows.begin() + 2));
  }
  // A trigger makes the insert of the fourth row (index 3000) fail.
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "CREATE TRIGGER fail BEFORE INSERT ON evaluation WHEN NEW.idx = 3000 "
                         "BEGIN SELECT RAISE(ABORT, 'refused'); END;",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  sqlite3_close(db);
  {
    ResultStore store(path, e, 1, true);
    EXPECT_THROW(store.InsertBatch(std::vector<EvaluationRow>(rows.begin() + 2, rows.end())),
                 std::runtime_error);
    // The store still works after the rollback.
    store.Insert(rows[2]);
  }
  const auto stored = ResultStore(path).Evaluations();
  ASSERT_EQ(stored.size(), 3u);  // the first two and rows[2]; nothing of the failed batch
  EXPECT_EQ(stored[2].index, rows[2].index);
}

TEST(SleepPlanner, DrawsAreSeededAndFollowTheMedian) {
  test::SleepPlannerOptions o;
  o.resolve_median_s = 1e-5;  // keep the test's sleeps short
  o.resolve_p95_s = 2e-5;
  o.flight_median_s = 1e-3;
  o.flight_p95_s = 2e-3;
  o.queries_per_flight = 20;
  const Planner planner{test::SleepPlanner{o}};
  EXPECT_EQ(planner.Name(), "sleep");
  std::vector<Opaque> queries;
  WorkerSlot slot;
  FlightRequest req;
  req.map = planner.PrepareMap(4);
  req.params = {{"effort", 1.0}, {"pace", 2.0}};
  req.seed = 9;
  req.on_query = [&](const Opaque& q) { queries.push_back(q); };
  const FlightRecord f = planner.Fly(req, slot);
  ASSERT_EQ(queries.size(), 20u);
  EXPECT_EQ(f.queries, 20);
  EXPECT_DOUBLE_EQ(f.flight_time, 10.0);
  EXPECT_GT(f.wall_time, 0.0);
  // Same query and θ_s: the same drawn cost; effort 1 is the cheapest on average.
  std::vector<double> at_one;
  std::vector<double> at_three;
  for (const auto& q : queries) {
    const ResolveRecord a = planner.Resolve(q, {{"effort", 1.0}});
    EXPECT_EQ(a.compute_units, planner.Resolve(q, {{"effort", 1.0}}).compute_units);
    at_one.push_back(a.compute_units);
    at_three.push_back(planner.Resolve(q, {{"effort", 3.0}}).compute_units);
  }
  std::sort(at_one.begin(), at_one.end());
  std::sort(at_three.begin(), at_three.end());
  const double median_units = 0.5 * (at_one[9] + at_one[10]);
  EXPECT_GT(median_units, 0.05);  // 1e-5 s = 0.1 units; log-normal with p95 at twice the median
  EXPECT_LT(median_units, 0.2);
  EXPECT_GT(at_three[10], at_one[10]);
  // A flight flown again with the same seed reports the same queries' costs.
  std::vector<Opaque> again;
  req.on_query = [&](const Opaque& q) { again.push_back(q); };
  (void)planner.Fly(req, slot);
  ASSERT_EQ(again.size(), queries.size());
  EXPECT_EQ(planner.Resolve(again[7], {{"effort", 0.7}}).compute_units,
            planner.Resolve(queries[7], {{"effort", 0.7}}).compute_units);
}

TEST(SleepPlanner, ExperimentFileSelectsItAndChecksItsKeys) {
  const std::string yaml =
      "name: sleep\nseed: 1\nthreads: 1\nmode: reproducible\nrepeats: 1\nmethods: [pso]\n"
      "planner:\n  type: sleep\n  sleep: {resolve_median_s: 1.0e-5, resolve_p95_s: 2.0e-5,"
      " flight_median_s: 1.0e-3, flight_p95_s: 2.0e-3, queries_per_flight: 10}\n"
      "parameters:\n  - {name: effort, lower: 0.25, upper: 4.0, default: 1.0}\n"
      "  - {name: pace, lower: 0.5, upper: 4.0, default: 1.0}\n"
      "short_term: [effort]\nlong_term: [pace]\n"
      "budget: {flights: 2, flight_batch: 1, short_evals_per_flight: 3, queries_per_eval: 2}\n"
      "pso: {num_particles: 3}\n";
  const Experiment e = Experiment::FromString(yaml);
  EXPECT_EQ(e.planner.Name(), "sleep");
  RunOptions o;
  const RunSummary s = RunExperiment(e, o);
  ASSERT_EQ(s.trials.size(), 1u);
  EXPECT_EQ(s.trials[0].flights, 2);
  std::string bad = yaml;
  bad.replace(bad.find("resolve_p95_s: 2.0e-5"), 21, "resolve_p95_s: 1.0e-6");
  EXPECT_TRUE(ThrowsConfigError([&] { (void)Experiment::FromString(bad); },
                                "planner.sleep.resolve_p95_s", {"must be >= resolve_median_s"}));
  std::string unknown = yaml;
  unknown.replace(unknown.find("queries_per_flight"), 18, "queries_per_fligth");
  EXPECT_TRUE(ThrowsConfigError([&] { (void)Experiment::FromString(unknown); },
                                "planner.sleep.queries_per_fligth",
                                {"unknown key", "queries_per_flight"}));
}

}  // namespace
}  // namespace quadtune::engine
