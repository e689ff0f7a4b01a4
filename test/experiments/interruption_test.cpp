// The result directory under concurrency and signals, through the `quadtune` program:
// - two runs (and two sweeps) into one --out: the second is refused naming the first's pid; the
//   first completes;
// - `run` into a used directory without --resume/--overwrite fails and leaves the store as it was;
// - SIGTERM during a run exits 130 with a consistent store, and --resume then completes with the
//   same evaluations as an uninterrupted run;
// - SIGTERM during layout generation (maps are made before the first flight) exits 130.
// No wall-clock limits: the tests wait for the program, and check exit codes and stores.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "../cli_util.hpp"

extern char** environ;

namespace quadtune::test {
namespace {

namespace fs = std::filesystem;

/// A toy experiment whose flights each sleep `delay` seconds (so a run lasts long enough to be
/// interrupted or raced); results do not depend on the delay.
std::string SlowToy(double delay) {
  return "name: slow\nseed: 5\nthreads: 2\nrepeats: 1\nmethods: [random, bo_pso]\n"
         "planner:\n  type: toy\n  toy: {length: 20, gates: 6, flight_delay_s: " +
         std::to_string(delay) +
         "}\n"
         "parameters:\n"
         "  - {name: gain, lower: 0.05, upper: 1.5, default: 0.3}\n"
         "  - {name: max_iter, lower: 2, upper: 40, type: integer, default: 20}\n"
         "  - {name: speed, lower: 0.5, upper: 6.0, default: 2.0}\n"
         "  - {name: margin, lower: 0.0, upper: 3.0, default: 0.5}\n"
         "short_term: [gain, max_iter]\nlong_term: [speed, margin]\n"
         "budget: {flights: 8, flight_batch: 1, short_evals_per_flight: 4}\n"
         "pso: {num_particles: 4}\nbo: {initial_design_size: 3, acquisition_pool: 100}\n";
}

struct Child {
  pid_t pid = -1;
  fs::path err;
};

/// Starts `quadtune args...` without waiting; stdout and stderr go to files next to `err`.
Child Start(const std::vector<std::string>& args, const fs::path& err) {
  std::vector<std::string> argv_s{QuadtuneBinary()};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  const std::string out = err.string() + ".out";
  posix_spawn_file_actions_addopen(&fa, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  Child c;
  c.err = err;
  EXPECT_EQ(posix_spawn(&c.pid, argv[0], &fa, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&fa);
  return c;
}

/// Exit code of the child (-1 when it did not exit normally).
int Wait(const Child& c) {
  int status = 0;
  waitpid(c.pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// Runs `quadtune args` to the end; returns its exit code; stderr into `err`.
int RunToEnd(const std::vector<std::string>& args, const fs::path& err) {
  return Wait(Start(args, err));
}

/// Rows of `sql` on the store, each row's columns joined by '|'.
std::vector<std::string> Rows(const fs::path& db, const std::string& sql) {
  std::vector<std::string> rows;
  sqlite3* h = nullptr;
  if (sqlite3_open_v2(db.c_str(), &h, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    sqlite3_close(h);
    return rows;
  }
  sqlite3_busy_timeout(h, 5000);
  sqlite3_stmt* st = nullptr;
  if (sqlite3_prepare_v2(h, sql.c_str(), -1, &st, nullptr) == SQLITE_OK) {
    while (sqlite3_step(st) == SQLITE_ROW) {
      std::string row;
      for (int c = 0; c < sqlite3_column_count(st); ++c) {
        const auto* t = sqlite3_column_text(st, c);
        row += (c ? "|" : "") + std::string(t ? reinterpret_cast<const char*>(t) : "");
      }
      rows.push_back(row);
    }
  }
  sqlite3_finalize(st);
  sqlite3_close(h);
  return rows;
}

int EvaluationCount(const fs::path& db) {
  const auto rows = Rows(db, "SELECT COUNT(*) FROM evaluation");
  return rows.empty() ? -1 : std::stoi(rows[0]);
}

/// Polls until `ready()` holds or the child has ended (no time limit: the test harness has one).
template <class F>
void WaitUntil(const Child& c, F ready) {
  while (!ready()) {
    if (kill(c.pid, 0) != 0) return;
    int status = 0;
    if (waitpid(c.pid, &status, WNOHANG) == c.pid) {
      ADD_FAILURE() << "the run ended before the condition held";
      return;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

/// Everything an evaluation decided (not its timing), in a stable order.
const char* kEvaluations =
    "SELECT t.method, e.kind, e.iteration, e.idx, e.params, e.value, e.status FROM evaluation e "
    "JOIN trial t ON t.id = e.trial_id ORDER BY t.method, e.kind, e.iteration, e.idx";

class Interruption : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("qt_interrupt_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(Interruption, SecondRunIntoTheSameDirectoryIsRefusedAndTheFirstCompletes) {
  std::ofstream(dir_ / "a.yaml") << SlowToy(0.15);
  std::ofstream(dir_ / "b.yaml") << SlowToy(0.0);
  const fs::path out = dir_ / "out";
  const Child first =
      Start({"run", "--no-plot", (dir_ / "a.yaml").string(), "--out", out.string(), "--quiet"},
            dir_ / "first.err");
  // The first holds the lock once its pid is in the lock file.
  WaitUntil(first, [&] { return !ReadText(out / ".quadtune.lock").empty(); });
  const int second = RunToEnd({"run", "--no-plot", (dir_ / "b.yaml").string(), "--out",
                               out.string(), "--overwrite", "--quiet"},
                              dir_ / "second.err");
  const int resume = RunToEnd({"run", "--no-plot", (dir_ / "a.yaml").string(), "--out",
                               out.string(), "--resume", "--quiet"},
                              dir_ / "resume.err");
  EXPECT_EQ(Wait(first), 0) << ReadText(dir_ / "first.err");
  EXPECT_EQ(second, 2);
  const std::string message = ReadText(dir_ / "second.err");
  EXPECT_NE(message.find(out.string()), std::string::npos) << message;
  EXPECT_NE(message.find("pid " + std::to_string(first.pid)), std::string::npos) << message;
  EXPECT_EQ(resume, 2) << ReadText(dir_ / "resume.err");
  EXPECT_NE(ReadText(dir_ / "resume.err").find("pid " + std::to_string(first.pid)),
            std::string::npos);
  // The first's store is complete: both trials done, 8 flights each, seeded by a.yaml.
  const fs::path store = out / "results.sqlite";
  EXPECT_EQ(Rows(store, "SELECT status FROM trial ORDER BY method"),
            (std::vector<std::string>{"done", "done"}));
  EXPECT_EQ(Rows(store, "SELECT COUNT(*) FROM evaluation WHERE kind='long'"),
            std::vector<std::string>{"16"});
  EXPECT_NE(Rows(store, "SELECT config FROM experiment")[0].find("flight_delay_s: 0.15"),
            std::string::npos);
}

TEST_F(Interruption, SecondSweepIntoTheSameDirectoryIsRefusedAndTheFirstCompletes) {
  std::ofstream(dir_ / "a.yaml") << SlowToy(0.2);
  const fs::path out = dir_ / "out";
  const std::vector<std::string> sweep{"sweep",     (dir_ / "a.yaml").string(),
                                       "--out",     out.string(),
                                       "--points",  "4",
                                       "--maps",    "1",
                                       "--queries", "2",
                                       "--no-plot", "--quiet"};
  const Child first = Start(sweep, dir_ / "first.err");
  WaitUntil(first, [&] { return !ReadText(out / ".quadtune.lock").empty(); });
  std::vector<std::string> again = sweep;
  again.push_back("--overwrite");
  const int second = RunToEnd(again, dir_ / "second.err");
  EXPECT_EQ(Wait(first), 0) << ReadText(dir_ / "first.err");
  EXPECT_EQ(second, 2);
  const std::string message = ReadText(dir_ / "second.err");
  EXPECT_NE(message.find(out.string()), std::string::npos) << message;
  EXPECT_NE(message.find("pid " + std::to_string(first.pid)), std::string::npos) << message;
  // The first's files are whole: a header and 4 × (4 + 2) points of one map.
  const std::string csv = ReadText(out / "points.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 1 + 4 * 6) << csv;
  EXPECT_FALSE(ReadText(out / "summary.json").empty());
}

TEST_F(Interruption, RunIntoAUsedDirectoryNeedsResumeOrOverwrite) {
  std::ofstream(dir_ / "a.yaml") << SlowToy(0.0);
  const fs::path out = dir_ / "out";
  ASSERT_EQ(
      RunToEnd({"run", "--no-plot", (dir_ / "a.yaml").string(), "--out", out.string(), "--quiet"},
               dir_ / "1.err"),
      0);
  const std::string store = ReadText(out / "results.sqlite");
  ASSERT_FALSE(store.empty());
  EXPECT_EQ(
      RunToEnd({"run", "--no-plot", (dir_ / "a.yaml").string(), "--out", out.string(), "--quiet"},
               dir_ / "2.err"),
      2);
  const std::string message = ReadText(dir_ / "2.err");
  EXPECT_NE(message.find("--resume"), std::string::npos) << message;
  EXPECT_NE(message.find("--overwrite"), std::string::npos) << message;
  EXPECT_EQ(ReadText(out / "results.sqlite"), store) << "the refused run changed the store";
  // --overwrite replaces the run (and removes what the old one wrote).
  std::ofstream(out / "tuning.png") << "old figure";
  EXPECT_EQ(RunToEnd({"run", "--no-plot", (dir_ / "a.yaml").string(), "--out", out.string(),
                      "--overwrite", "--quiet"},
                     dir_ / "3.err"),
            0)
      << ReadText(dir_ / "3.err");
  EXPECT_FALSE(fs::exists(out / "tuning.png"));
  EXPECT_EQ(Rows(out / "results.sqlite", "SELECT COUNT(*) FROM experiment"),
            std::vector<std::string>{"1"});
}

TEST_F(Interruption, SigtermDuringARunLeavesAConsistentStoreThatResumesToTheSameResult) {
  std::ofstream(dir_ / "slow.yaml") << SlowToy(0.1);
  std::ofstream(dir_ / "fast.yaml") << SlowToy(0.1);
  const fs::path out = dir_ / "out";
  const Child run =
      Start({"run", "--no-plot", (dir_ / "slow.yaml").string(), "--out", out.string(), "--quiet"},
            dir_ / "run.err");
  WaitUntil(run, [&] { return EvaluationCount(out / "results.sqlite") >= 3; });
  kill(run.pid, SIGTERM);
  EXPECT_EQ(Wait(run), 130) << ReadText(dir_ / "run.err");
  const std::string message = ReadText(dir_ / "run.err");
  EXPECT_NE(message.find("--resume"), std::string::npos) << message;
  EXPECT_EQ(Rows(out / "results.sqlite", "PRAGMA integrity_check"), std::vector<std::string>{"ok"});
  const int stored = EvaluationCount(out / "results.sqlite");
  EXPECT_GE(stored, 3);
  EXPECT_LT(stored, 2 * 8 + 8 * 4) << "the run was not interrupted";
  ASSERT_EQ(RunToEnd({"run", "--no-plot", (dir_ / "slow.yaml").string(), "--out", out.string(),
                      "--resume", "--quiet"},
                     dir_ / "resume.err"),
            0)
      << ReadText(dir_ / "resume.err");
  const fs::path ref = dir_ / "ref";
  ASSERT_EQ(RunToEnd({"run", "--no-plot", (dir_ / "fast.yaml").string(), "--out", ref.string(),
                      "--quiet"},
                     dir_ / "ref.err"),
            0);
  const auto resumed = Rows(out / "results.sqlite", kEvaluations);
  EXPECT_FALSE(resumed.empty());
  EXPECT_EQ(resumed, Rows(ref / "results.sqlite", kEvaluations));
}

TEST_F(Interruption, SigtermDuringAShortTermPhaseResumesToTheSameResult) {
  // bo_pso on the sleep planner: each generation re-solves 4 × 40 queries of about 10 ms.
  const std::string yaml =
      "name: short\nseed: 6\nthreads: 2\nmode: reproducible\nrepeats: 1\nmethods: [bo_pso]\n"
      "planner:\n  type: sleep\n  sleep: {resolve_median_s: 0.01, resolve_p95_s: 0.02,"
      " flight_median_s: 0.01, flight_p95_s: 0.02, queries_per_flight: 10}\n"
      "parameters:\n  - {name: effort, lower: 0.25, upper: 4.0, default: 1.0}\n"
      "  - {name: pace, lower: 0.5, upper: 4.0, default: 1.0}\n"
      "short_term: [effort]\nlong_term: [pace]\n"
      "budget: {flights: 3, flight_batch: 1, short_evals_per_flight: 8, queries_per_eval: 40}\n"
      "pso: {num_particles: 4}\nbo: {initial_design_size: 2, acquisition_pool: 100}\n";
  std::ofstream(dir_ / "short.yaml") << yaml;
  const fs::path out = dir_ / "out";
  const Child run =
      Start({"run", "--no-plot", (dir_ / "short.yaml").string(), "--out", out.string(), "--quiet"},
            dir_ / "run.err");
  const auto shorts = [&] {
    const auto rows =
        Rows(out / "results.sqlite", "SELECT COUNT(*) FROM evaluation WHERE kind='short'");
    return rows.empty() ? 0 : std::stoi(rows[0]);
  };
  WaitUntil(run, [&] { return shorts() >= 4; });
  kill(run.pid, SIGTERM);
  EXPECT_EQ(Wait(run), 130) << ReadText(dir_ / "run.err");
  EXPECT_EQ(Rows(out / "results.sqlite", "PRAGMA integrity_check"), std::vector<std::string>{"ok"});
  EXPECT_LT(shorts(), 3 * 8) << "the run was not interrupted";
  const fs::path ref = dir_ / "ref";
  for (const bool resume : {true, false}) {  // finish the interrupted run; run it uninterrupted
    std::vector<std::string> args{"run", "--no-plot", (dir_ / "short.yaml").string(), "--out",
                                  (resume ? out : ref).string(), "--quiet"};
    if (resume) args.push_back("--resume");
    const fs::path err = dir_ / (resume ? "resume.err" : "ref.err");
    ASSERT_EQ(RunToEnd(args, err), 0) << ReadText(err);
  }
  const auto resumed = Rows(out / "results.sqlite", kEvaluations);
  EXPECT_FALSE(resumed.empty());
  EXPECT_EQ(resumed, Rows(ref / "results.sqlite", kEvaluations));
}

TEST_F(Interruption, SigtermDuringLayoutGenerationExitsWithTheResumeCommand) {
  // A large forest: its map is generated before the first flight, for seconds.
  std::ofstream(dir_ / "big.yaml")
      << "name: big\nseed: 1\nmethods: [default]\nplanner:\n  type: ipopt\n"
         "  layout:\n    region: {min: [0.0, -150.0], max: [300.0, 150.0]}\n"
         "    mission: {start: [0.0, 0.0, 1.2], goal: [300.0, 0.0, 1.2], keep_out_radius: 1.5}\n"
         "    spacing: 0.9\n    min_gap: 0.2\n"
         "    obstacles:\n      ring_fraction: 0.0\n"
         "      cylinder: {radius: [0.125, 0.3], height: [3.0, 3.0]}\n"
         "parameters:\n"
         "  - {name: w_col, lower: 0.05, upper: 5.0, default: 0.5}\n"
         "  - {name: v_des, lower: 0.5, upper: 4.0, default: 2.0}\n"
         "short_term: [w_col]\nlong_term: [v_des]\n"
         "budget: {flights: 1}\n";
  const fs::path out = dir_ / "out";
  const Child run =
      Start({"run", "--no-plot", (dir_ / "big.yaml").string(), "--out", out.string(), "--quiet"},
            dir_ / "run.err");
  // The store is written before the maps are generated.
  WaitUntil(run,
            [&] { return !Rows(out / "results.sqlite", "SELECT id FROM experiment").empty(); });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  kill(run.pid, SIGTERM);
  EXPECT_EQ(Wait(run), 130) << ReadText(dir_ / "run.err");
  EXPECT_NE(ReadText(dir_ / "run.err").find("--resume"), std::string::npos);
  EXPECT_EQ(Rows(out / "results.sqlite", "PRAGMA integrity_check"), std::vector<std::string>{"ok"});
  EXPECT_EQ(EvaluationCount(out / "results.sqlite"), 0);
}

}  // namespace
}  // namespace quadtune::test
