#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <thread>

#include "../process_util.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/store/result_store.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "test_util.hpp"
#include "toy_planners.hpp"

namespace quadtune::engine {
namespace {

std::map<std::string, std::pair<int, int>> CountByMethod(const std::string& store_path) {
  std::map<std::string, std::pair<int, int>> counts;  // method → (long, short)
  ResultStore store(store_path);
  for (const auto& r : store.Evaluations()) {
    auto& c = counts[ToString(r.method)];
    (r.kind == EvalKind::kLong ? c.first : c.second) += 1;
  }
  return counts;
}

TEST(PlannerPlugin, ToyPlannerFliesAndResolvesItsQueries) {
  const Planner planner{test::ToyPlanner{}};
  EXPECT_EQ(planner.Name(), "toy");
  EXPECT_EQ(planner.Defaults().size(), 4u);
  WorkerSlot slot;
  std::vector<Opaque> queries;
  FlightRequest req;
  req.map = planner.PrepareMap(1);
  req.params = planner.Defaults();
  req.seed = 5;
  req.on_query = [&](const Opaque& q) { queries.push_back(q); };
  const FlightRecord f = planner.Fly(req, slot);
  EXPECT_TRUE(f.completed);
  EXPECT_GT(f.flight_time, 0.0);
  ASSERT_EQ(static_cast<int>(queries.size()), f.queries);
  ASSERT_FALSE(queries.empty());
  const ResolveRecord good = planner.Resolve(queries[0], {{"gain", 0.6}, {"max_iter", 40}});
  const ResolveRecord bad = planner.Resolve(queries[0], {{"gain", 0.6}, {"max_iter", 2}});
  EXPECT_TRUE(good.success);
  EXPECT_FALSE(bad.success);
  EXPECT_GT(bad.failed_attempts, 0);
  // A copy of the type-erased planner is an independent value that behaves the same.
  const Planner copy = planner;  // NOLINT(performance-unnecessary-copy-initialization)
  EXPECT_EQ(copy.Resolve(queries[0], {{"gain", 0.6}, {"max_iter", 40}}).compute_units,
            good.compute_units);
  EXPECT_NE(copy.Extract<test::ToyPlanner>(), nullptr);
  EXPECT_EQ(copy.Extract<IpoptPlanner>(), nullptr);
}

TEST(Tuner, EachMethodGivesCompleteResultSet) {
  const std::string dir = test::TempDir("complete");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  const Experiment e = Experiment::FromString(test::ToyYaml(), "toy.yaml");
  const RunSummary s = RunExperiment(e, o);
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  ASSERT_EQ(s.trials.size(), 5u);
  const auto counts = CountByMethod(o.store_path);
  for (const char* m : {"default", "random", "pso", "bo", "bo_pso"}) {
    ASSERT_TRUE(counts.count(m)) << m;
    EXPECT_EQ(counts.at(m).first, 6) << m;  // budget.flights long-term evaluations
  }
  // bo_pso: θ_s first (4 evaluations on the first flight's queries), then rounds of 2, 2, 1
  // flights with 4 θ_s evaluations per flight.
  EXPECT_EQ(counts.at("bo_pso").second, 4 + 8 + 8 + 4);
  EXPECT_EQ(counts.at("bo").second, 0);
  ResultStore store(o.store_path);
  for (const auto& t : store.Trials()) {
    EXPECT_EQ(t.status, TrialStatus::kDone) << ToString(t.method);
    EXPECT_GT(t.best_value, 0.0) << ToString(t.method);
  }
  for (const auto& r : store.Evaluations()) {
    EXPECT_EQ(r.status, EvalStatus::kOk) << ToString(r.method) << " " << r.message;
    EXPECT_NE(r.params.find('{'), std::string::npos);
    EXPECT_GT(r.finished, 0.0);
    const char* key = r.kind == EvalKind::kLong ? "\"t_f\"" : "\"J_t\"";
    EXPECT_NE(r.terms.find(key), std::string::npos) << ToString(r.kind);
  }
  // CSV export.
  store.ExportCsv(dir + "/csv");
  std::ifstream csv(dir + "/csv/evaluations.csv");
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 1 + 5 * 6 + 24);
}

// A refinement stage (`start:` with moving bounds) whose start sits on the bounds of an integer
// parameter: its first bounds reach half a cell past the range in the unit cube, and must be
// clamped to the range instead of rejected (the refinement study once stopped on n_pol = 10).
TEST(Tuner, RefinementStartOnTheBoundsOfAnIntegerParameterRuns) {
  for (const char* max_iter : {"2", "40"}) {
    std::string yaml = test::ToyYaml("[bo]", "", 4);
    const std::string bo = "bo: {initial_design_size: 2,";
    yaml.replace(yaml.find(bo), bo.size(),
                 "bo: {moving_bounds: {enabled: true, damping: 0.8, half_width: 0.1}, "
                 "initial_design_size: 2,");
    yaml += std::string("start: {gain: 1.5, max_iter: ") + max_iter + ", speed: 0.5, margin: 3.0}\n";
    const Experiment e = Experiment::FromString(yaml, "toy.yaml");
    RunOptions o;
    const RunSummary s = RunExperiment(e, o);
    ASSERT_EQ(s.status, RunStatus::kCompleted) << max_iter;
    ASSERT_EQ(s.trials.size(), 1u);
    EXPECT_EQ(s.trials[0].flights, 4) << max_iter;
  }
}

TEST(Tuner, ToyPlannerIsTunedBelowItsDefaultsOnHeldOutMaps) {
  RunOptions o;
  // Gates allow 4–6 m/s on every map, so flying faster than the default 2 m/s pays everywhere.
  const Experiment e = Experiment::FromString(
      test::ToyYaml("[default, bo_pso]", ", gate_speed_min: 4.0, gate_speed_max: 6.0", 16, 8),
      "toy.yaml");
  const RunSummary s = RunExperiment(e, o);
  ASSERT_EQ(s.trials.size(), 2u);
  // Every flight flies its own map, so the best flights of two trials are not comparable; the
  // recommended point and the defaults on the same held-out maps are.
  ASSERT_EQ(s.validation.size(), 3u);  // the defaults, the default trial, bo_pso
  EXPECT_EQ(s.validation[2].method, "bo_pso");
  EXPECT_LT(s.validation[2].mean_value, s.validation[0].mean_value);
  EXPECT_GT(s.resolves, 0);
}

TEST(Tuner, BestShortTermParametersFlowIntoLaterFlights) {
  const std::string dir = test::TempDir("flow");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  const RunSummary s = RunExperiment(Experiment::FromString(test::ToyYaml("[bo_pso]"), "t.yaml"), o);
  ASSERT_EQ(s.trials.size(), 1u);
  EXPECT_GT(s.trials[0].context_changes, 0);  // BO was told that θ_s changed
  // The first round's flights (iteration 1) fly the best θ_s of the θ_s-first phase
  // (generation 0, evaluated on the queries of the default flight at iteration 0).
  const auto rows = ResultStore(o.store_path).Evaluations();
  const EvaluationRow* best = nullptr;
  for (const auto& r : rows) {
    if (r.kind == EvalKind::kShort && r.iteration == 0 && (best == nullptr || r.value < best->value)) best = &r;
  }
  ASSERT_NE(best, nullptr);
  const auto theta_s = nlohmann::json::parse(best->params);
  int checked = 0;
  for (const auto& r : rows) {
    if (r.kind != EvalKind::kLong || r.iteration != 1) continue;
    const auto p = nlohmann::json::parse(r.params);
    EXPECT_EQ(p["gain"], theta_s["gain"]);
    EXPECT_EQ(p["max_iter"], theta_s["max_iter"]);
    ++checked;
  }
  EXPECT_EQ(checked, 2);
}

TEST(Tuner, GivenInitialShortTermParametersSkipTheFirstPhase) {
  const std::string dir = test::TempDir("initial");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  const std::string text =
      test::ToyYaml("[bo_pso]") + "initial_short_term: {gain: 0.7, max_iter: 30}\n";
  (void)RunExperiment(Experiment::FromString(text, "t.yaml"), o);
  // No θ_s-first flight: BO flies rounds of 2 from the start; PSO runs on the queries of earlier
  // rounds (none in the first round), 4 evaluations per flight.
  EXPECT_EQ(CountByMethod(o.store_path).at("bo_pso"), std::make_pair(6, 8 + 8));
  for (const auto& r : ResultStore(o.store_path).Evaluations()) {
    if (r.kind != EvalKind::kLong || r.iteration != 0) continue;
    const auto p = nlohmann::json::parse(r.params);
    EXPECT_DOUBLE_EQ(p["gain"].get<double>(), 0.7);
    EXPECT_DOUBLE_EQ(p["max_iter"].get<double>(), 30.0);
  }
}

TEST(Tuner, RealtimeModeRunsToCompletion) {
  std::string text = test::ToyYaml("[bo_pso]");
  text.replace(text.find("mode: reproducible"), 18, "mode: realtime");
  const std::string dir = test::TempDir("realtime");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  const RunSummary s = RunExperiment(Experiment::FromString(text, "t.yaml"), o);
  EXPECT_EQ(s.status, RunStatus::kCompleted);
  EXPECT_EQ(CountByMethod(o.store_path).at("bo_pso"), std::make_pair(6, 24));
}

TEST(Tuner, RealtimeShortTermWhileFlyingRunsAtLeastTheCountedEvaluations) {
  std::string text = test::ToyYaml("[bo_pso]", ", flight_delay_s: 0.01");
  text.replace(text.find("mode: reproducible"), 18, "mode: realtime");
  text.replace(text.find("query_window: 50"), 16, "query_window: 50, short_term_while_flying: true");
  const std::string dir = test::TempDir("while_flying");
  RunOptions o;
  o.store_path = dir + "/r.sqlite";
  const RunSummary s = RunExperiment(Experiment::FromString(text, "t.yaml"), o);
  EXPECT_EQ(s.status, RunStatus::kCompleted);
  const auto counts = CountByMethod(o.store_path).at("bo_pso");
  EXPECT_EQ(counts.first, 6);
  EXPECT_GE(counts.second, 24);
}

TEST(Tuner, SameSeedSameResultsAt1And2And8Threads) {
  std::vector<std::vector<std::string>> runs;
  for (int threads : {1, 2, 8}) {
    const std::string dir = test::TempDir("threads" + std::to_string(threads));
    RunOptions o;
    o.store_path = dir + "/r.sqlite";
    o.threads = threads;
    const RunSummary s = RunExperiment(Experiment::FromString(test::ToyYaml(), "toy.yaml"), o);
    EXPECT_EQ(s.threads, threads);
    runs.push_back(test::Deterministic(o.store_path));
  }
  ASSERT_FALSE(runs[0].empty());
  EXPECT_EQ(runs[0], runs[1]);
  EXPECT_EQ(runs[0], runs[2]);
}

/// A toy experiment whose flights throw above `throw_speed` (m/s), run to completion in its own
/// store.
struct ThrowingRun {
  ThrowingRun(const std::string& name, const char* methods, double throw_speed, int flights)
      : e(Experiment::FromString(
            test::ToyYaml(methods, ", throw_speed_above: " + std::to_string(throw_speed), flights),
            "toy.yaml")) {
    o.store_path = test::TempDir(name) + "/r.sqlite";
    s = RunExperiment(e, o);
  }
  Experiment e;
  RunOptions o;
  RunSummary s;
};

TEST(Tuner, ThrowingFlightIsRecordedAsFailedAndRunCompletes) {
  const ThrowingRun run("throwing", "[random, bo_pso]", 3.0, 8);
  const Experiment& e = run.e;
  const RunOptions& o = run.o;
  ASSERT_EQ(run.s.status, RunStatus::kCompleted);
  int failed = 0;
  for (const auto& r : ResultStore(o.store_path).Evaluations()) {
    if (r.status == EvalStatus::kFailed) {
      ++failed;
      EXPECT_NE(r.message.find("exception: toy planner: speed"), std::string::npos) << r.message;
      EXPECT_DOUBLE_EQ(r.value, e.objective.failure_value);
    }
  }
  EXPECT_GT(failed, 0);
  const auto counts = CountByMethod(o.store_path);
  EXPECT_EQ(counts.at("random").first, 8);
  EXPECT_EQ(counts.at("bo_pso").first, 8);
}

TEST(Tuner, TrialWhoseEveryFlightFailedReportsTheFailureValue) {
  // Every speed in the box (0.5–6 m/s) is above 0.1: every flight throws.
  const ThrowingRun run("all_failed", "[default, random]", 0.1, 4);
  const Experiment& e = run.e;
  const RunSummary& s = run.s;
  ASSERT_EQ(s.status, RunStatus::kCompleted);
  ASSERT_EQ(s.trials.size(), 2u);
  for (const TrialSummary& t : s.trials) {
    EXPECT_EQ(t.failed, t.flights) << t.method;
    EXPECT_DOUBLE_EQ(t.best_value, e.objective.failure_value) << t.method;
  }
  for (const auto& t : ResultStore(run.o.store_path).Trials()) {
    EXPECT_DOUBLE_EQ(t.best_value, e.objective.failure_value) << ToString(t.method);
  }
}

class CancelResume : public ::testing::TestWithParam<std::pair<const char*, int>> {};

/// Cancels a run after N progress reports (i.e. rounds), resumes it, and compares with a run that
/// was never interrupted.
TEST_P(CancelResume, ResumedRunEqualsUninterruptedRun) {
  const auto [methods, cut_after] = GetParam();
  const Experiment e = Experiment::FromString(test::ToyYaml(methods), "toy.yaml");
  const auto r = test::CutThenResume(e, test::TempDir("cancel_resume" + std::to_string(cut_after)),
                                     cut_after);
  EXPECT_EQ(r.cut.status, RunStatus::kCancelled);
  EXPECT_LT(r.partial.size(), test::Deterministic(r.full).size());
  EXPECT_EQ(r.resumed.status, RunStatus::kCompleted);
  int replayed = 0;
  for (const auto& t : r.resumed.trials) replayed += t.replayed;
  EXPECT_EQ(replayed, static_cast<int>(r.partial.size()));
  EXPECT_EQ(test::Deterministic(r.part), test::Deterministic(r.full));
}

INSTANTIATE_TEST_SUITE_P(
    Tuner, CancelResume,
    ::testing::Values(std::make_pair("[default, random, pso, bo, bo_pso]", 7),  // inside pso
                      std::make_pair("[bo_pso]", 1),    // after the θ_s-first phase
                      std::make_pair("[bo_pso]", 3)));  // mid bo_pso: flights re-flown for queries

using ::quadtune::test::CountEvaluations;
using ::quadtune::test::Spawn;
using ::quadtune::test::WaitExit;

int CountRows(const std::string& path) { return CountEvaluations(path); }

TEST(Resume, KillMinus9MidRunThenResumeEqualsUninterruptedRun) {
  const std::string bin = QUADTUNE_CLI_PROGRAM;  // quadtune_test_cli
  ASSERT_TRUE(std::filesystem::exists(bin)) << bin;
  const std::string dir = test::TempDir("kill9");
  const std::string file = dir + "/toy.yaml";
  // Killed inside the bo_pso trial (after random's 6 flights), where resuming must also rebuild
  // the recorded-query buffer.
  std::ofstream(file) << test::ToyYaml("[random, bo_pso]", ", flight_delay_s: 0.03");
  // Uninterrupted reference.
  ASSERT_EQ(WaitExit(Spawn({bin, "--log-level", "warn", "run", "--no-plot", file, "--out",
                            dir + "/full", "--quiet"})),
            0);
  const auto reference = test::Deterministic(dir + "/full/results.sqlite");
  const int total = static_cast<int>(reference.size());
  ASSERT_GT(total, 20);

  // Killed run: kill -9 once some (not all) evaluations are stored.
  const std::string store = dir + "/cut/results.sqlite";
  const pid_t pid = Spawn(
      {bin, "--log-level", "warn", "run", "--no-plot", file, "--out", dir + "/cut", "--quiet"});
  int at_kill = 0;
  for (int i = 0; i < 4000; ++i) {
    at_kill = CountRows(store);
    if (at_kill >= 6 + 12) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run finished before it could be killed";
  const int stored = CountRows(store);
  EXPECT_GT(stored, 0);
  EXPECT_LT(stored, total);

  ASSERT_EQ(WaitExit(Spawn({bin, "--log-level", "warn", "run", "--no-plot", file, "--out",
                            dir + "/cut", "--resume", "--quiet", "--threads", "1"})),
            0);
  EXPECT_EQ(test::Deterministic(store), reference);
}

TEST(Cli, ExportWritesCsvAndBenchRuns) {
  const std::string bin = QUADTUNE_CLI_PROGRAM;  // quadtune_test_cli
  ASSERT_TRUE(std::filesystem::exists(bin)) << bin;
  const std::string dir = test::TempDir("cli");
  const std::string file = dir + "/toy.yaml";
  std::ofstream(file) << test::ToyYaml("[bo]");
  ASSERT_EQ(WaitExit(Spawn({bin, "--log-level", "warn", "run", "--no-plot", file, "--out",
                            dir + "/run", "--quiet", "--threads", "2"})),
            0);
  ASSERT_EQ(WaitExit(Spawn({bin, "--log-level", "warn", "export", dir + "/run/results.sqlite",
                            "--csv", dir + "/csv"})), 0);
  std::ifstream csv(dir + "/csv/evaluations.csv");
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 1 + 6);
  // trials.csv: the one bo trial, done; summary.json: the same trial with its 6 flights.
  std::ifstream trials(dir + "/csv/trials.csv");
  std::vector<std::string> trial_lines;
  for (std::string line; std::getline(trials, line);) trial_lines.push_back(line);
  ASSERT_EQ(trial_lines.size(), 2u);
  EXPECT_NE(trial_lines[1].find("bo"), std::string::npos) << trial_lines[1];
  EXPECT_NE(trial_lines[1].find("done"), std::string::npos) << trial_lines[1];
  const auto summary = nlohmann::json::parse(std::ifstream(dir + "/run/summary.json"));
  EXPECT_EQ(summary["status"], "completed");
  ASSERT_EQ(summary["trials"].size(), 1u);
  EXPECT_EQ(summary["trials"][0]["method"], "bo");
  EXPECT_EQ(summary["trials"][0]["flights"], 6);
  EXPECT_EQ(summary["flights"], 6);
  const auto stored = test::Deterministic(dir + "/run/results.sqlite");
  EXPECT_EQ(stored.size(), 6u);
  // The bench reports its table: one row per thread count.
  EXPECT_EQ(WaitExit(Spawn({bin, "--log-level", "warn", "bench", file, "--max-threads", "2",
                            "--flights", "4", "--resolves", "50", "--csv", dir + "/bench.csv"})),
            0);
  std::ifstream bench(dir + "/bench.csv");
  int bench_lines = 0;
  for (std::string line; std::getline(bench, line);) ++bench_lines;
  EXPECT_EQ(bench_lines, 1 + 2);
  // A configuration error stops `run` before any work, with exit code 2.
  std::ofstream(dir + "/bad.yaml") << test::ToyYaml("[annealing]");
  EXPECT_EQ(WaitExit(Spawn({bin, "--log-level", "off", "run", "--no-plot", dir + "/bad.yaml",
                            "--out", dir + "/bad"})),
            2);
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad/results.sqlite"));
}

}  // namespace
}  // namespace quadtune::engine
