// Rank 0's side of a distributed run in a burst: batches of encoded rows (as the ranks send
// them) decoded and committed, many messages per transaction, as the serving loop does
// (distributed.hpp); against it, one transaction per row (the single-process path).
//
//   build/test/engine/store_bench --benchmark_counters_tabular=true
//
// items_per_second is stored evaluations per second.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>
#include <vector>

#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/store/row_codec.hpp"

namespace quadtune::engine {
namespace {

const char* kYaml =
    "name: bench\nseed: 1\nthreads: 1\nmode: reproducible\nrepeats: 1\nmethods: [pso]\n"
    "planner:\n  type: toy\n"
    "parameters:\n  - {name: gain, lower: 0.05, upper: 1.5}\n"
    "  - {name: max_iter, lower: 2, upper: 40, type: integer}\n"
    "  - {name: speed, lower: 0.5, upper: 6.0}\n  - {name: margin, lower: 0.0, upper: 3.0}\n"
    "short_term: [gain, max_iter]\nlong_term: [speed, margin]\n";

/// A short-term row of the size the tuner stores (parameters and every objective term).
EvaluationRow SampleRow(std::int64_t trial, int iteration, int index) {
  EvaluationRow r;
  r.trial_id = trial;
  r.method = Method::kBoPso;
  r.kind = EvalKind::kShort;
  r.iteration = iteration;
  r.index = index;
  r.params = "{\"w_col\":0.73128840911203,\"w_dyn\":0.0412093381297,\"n_pol\":6}";
  r.terms =
      "{\"attempts\":1.0,\"compute_units\":8.0,\"duration\":4.21930117,\"failed_attempts\":0.0,"
      "\"jerk_integral\":12.0912331,\"min_clearance\":0.412,\"queries\":8.0,\"solve_time\":"
      "0.00091223,\"success\":1.0,\"t_c\":0.0008,\"tau\":0.0}";
  r.value = 0.000812 + 1e-9 * index;
  r.status = EvalStatus::kOk;
  r.wall_s = 0.0091;
  r.started = 1.7e9 + index;
  r.finished = r.started + r.wall_s;
  return r;
}

/// Encoded batches of `rows_per_message` rows with keys not used before.
std::vector<std::string> Messages(int messages, int rows_per_message, int& next_index) {
  std::vector<std::string> out;
  for (int m = 0; m < messages; ++m) {
    RowBatch batch(static_cast<std::uint64_t>(m + 1));
    for (int i = 0; i < rows_per_message; ++i) batch.Add(SampleRow(1, 0, next_index++));
    out.push_back(batch.Bytes());
  }
  return out;
}

/// Arguments: rows per message, messages per transaction.
void BM_DecodeAndCommitBatches(benchmark::State& state) {
  const int rows_per_message = static_cast<int>(state.range(0));
  const int messages = static_cast<int>(state.range(1));
  const auto dir = std::filesystem::temp_directory_path() / "quadtune_store_bench";
  std::filesystem::create_directories(dir);
  const Experiment e = Experiment::FromString(kYaml);
  ResultStore store((dir / "burst.sqlite").string(), e, 1, false);
  int next_index = 0;
  std::vector<EvaluationRow> rows;
  for (auto _ : state) {
    state.PauseTiming();
    const auto bytes = Messages(messages, rows_per_message, next_index);
    rows.clear();
    state.ResumeTiming();
    for (const auto& m : bytes) DecodeBatch(m, rows);
    store.InsertBatch(rows);
  }
  state.SetItemsProcessed(state.iterations() * rows_per_message * messages);
}
BENCHMARK(BM_DecodeAndCommitBatches)
    ->Args({8, 64})
    ->Args({64, 64})
    ->Args({256, 16})
    ->Unit(benchmark::kMillisecond);

/// One row per transaction (the single-process path), for comparison.
void BM_InsertOneRowPerTransaction(benchmark::State& state) {
  const auto dir = std::filesystem::temp_directory_path() / "quadtune_store_bench";
  std::filesystem::create_directories(dir);
  const Experiment e = Experiment::FromString(kYaml);
  ResultStore store((dir / "single.sqlite").string(), e, 1, false);
  int index = 0;
  for (auto _ : state) store.Insert(SampleRow(1, 0, index++));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_InsertOneRowPerTransaction);

/// Encoding on a rank (its share of the cost of shipping a row).
void BM_EncodeRows(benchmark::State& state) {
  const EvaluationRow row = SampleRow(1, 0, 1);
  for (auto _ : state) {
    RowBatch batch(1);
    for (int i = 0; i < 256; ++i) batch.Add(row);
    benchmark::DoNotOptimize(batch.Bytes().data());
  }
  state.SetItemsProcessed(state.iterations() * 256);
}
BENCHMARK(BM_EncodeRows);

}  // namespace
}  // namespace quadtune::engine

BENCHMARK_MAIN();
