// `quadtune run` and `quadtune study` draw their own figures and browser report when they end
// (unless --no-plot); a failing figure script is one error line and exit 1 with the results
// kept; the study's progress lines carry an ETA. Toy planner, small budgets.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "../cli_util.hpp"

namespace quadtune {
namespace {

namespace fs = std::filesystem;
using test::FreshTempDir;
using test::PngBytes;
using test::QuadtuneBinary;
using test::ReadText;
using test::RunQuadtune;

const std::string kToy = test::ToyExperimentFile();
// Two trials of four flights and three validation maps: a run of about a second.
const std::string kSmall =
    " --set repeats=1 --set 'methods=[default, bo_pso]' --set budget.flights=4 "
    "--set budget.default_flights=2 --threads 2";

/// Lines of `text` that contain `needle`.
std::vector<std::string> LinesWith(const std::string& text, const std::string& needle) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    if (line.find(needle) != std::string::npos) out.push_back(line);
  }
  return out;
}

std::string Status(const fs::path& run) {
  return nlohmann::json::parse(ReadText(run / "summary.json")).at("status").get<std::string>();
}

/// Runs the small toy experiment with `options` into DIR/run (DIR/run.log); true when it exits 0
/// with a completed run.
bool RunSmallToy(const fs::path& dir, const std::string& options) {
  const int code = RunQuadtune(
      "run " + kToy + " --out " + (dir / "run").string() + " --quiet" + options + kSmall,
      dir / "run.log");
  return code == 0 && Status(dir / "run") == "completed";
}

TEST(RunFigures, RunDrawsItsFiguresTableAndReport) {
  const fs::path dir = FreshTempDir("quadtune_run_figures_draw");
  const fs::path out = dir / "run";
  ASSERT_TRUE(RunSmallToy(dir, "")) << ReadText(dir / "run.log");
  EXPECT_GT(PngBytes(out / "tuning.png"), 10000u);
  EXPECT_GT(PngBytes(out / "validation.png"), 10000u);
  const std::string table = ReadText(out / "tuning.md");
  EXPECT_NE(table.find("| BO+PSO | 1 | 4 |"), std::string::npos) << table;  // 1 repeat, 4 flights
  // The report holds the run's data (both methods) and the inlined libraries, nothing fetched.
  const std::string page = ReadText(out / "report.html");
  ASSERT_GT(page.size(), 100000u);
  EXPECT_NE(page.find("\"bo_pso\""), std::string::npos);
  EXPECT_NE(page.find("\"default\""), std::string::npos);
  EXPECT_EQ(page.find("src=\"http"), std::string::npos);
  // Where they are: the log names the report.
  EXPECT_EQ(LinesWith(ReadText(dir / "run.log"), "[info] report: " + (out / "report.html").string())
                .size(),
            1u)
      << ReadText(dir / "run.log");
}

TEST(RunFigures, NoPlotLeavesOnlyTheResults) {
  const fs::path dir = FreshTempDir("quadtune_run_figures_no_plot");
  const fs::path out = dir / "run";
  ASSERT_TRUE(RunSmallToy(dir, " --no-plot")) << ReadText(dir / "run.log");
  EXPECT_TRUE(fs::exists(out / "results.sqlite"));
  EXPECT_FALSE(fs::exists(out / "tuning.png"));
  EXPECT_FALSE(fs::exists(out / "tuning.md"));
  EXPECT_FALSE(fs::exists(out / "report.html"));
  // Drawn later from the same folder, as `run` would have.
  ASSERT_EQ(RunQuadtune("plot run " + out.string(), dir / "plot.log"), 0)
      << ReadText(dir / "plot.log");
  EXPECT_GT(PngBytes(out / "tuning.png"), 10000u);
}

TEST(RunFigures, FailingFigureScriptIsOneLineAndExitOneWithResultsKept) {
  const fs::path dir = FreshTempDir("quadtune_run_figures_broken");
  const fs::path script = dir / "broken_plot.py";
  std::ofstream(script) << "import sys\n"
                           "def draw():\n"
                           "    raise ValueError('no figure today')\n"
                           "print('partial output on stdout')\n"
                           "draw()\n";
  const fs::path out = dir / "run";
  const std::string command = "QUADTUNE_PLOT_SCRIPT='" + script.string() + "' " + QuadtuneBinary() +
                              " run " + kToy + " --out " + out.string() + " --quiet" + kSmall +
                              " > '" + (dir / "out.log").string() + "' 2> '" +
                              (dir / "err.log").string() + "'";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string err = ReadText(dir / "err.log");
  // One line says which script failed and why; no traceback.
  const auto errors = LinesWith(err, "[error]");
  ASSERT_EQ(errors.size(), 1u) << err;
  EXPECT_NE(errors[0].find("broken_plot.py failed: ValueError: no figure today"), std::string::npos)
      << errors[0];
  EXPECT_EQ(err.find("Traceback"), std::string::npos) << err;
  // The results stay: the store, the summary, and the report (drawn by its own script).
  EXPECT_EQ(Status(out), "completed");
  EXPECT_TRUE(fs::exists(out / "results.sqlite"));
  EXPECT_TRUE(fs::exists(out / "report.html"));
}

TEST(RunFigures, StudyProgressCarriesAnEtaAndNoPlotDrawsNothing) {
  const fs::path dir = FreshTempDir("quadtune_run_figures_study");
  fs::copy_file(kToy, dir / "toy.yaml");
  std::ofstream(dir / "study.yaml")
      << "name: toy-eta\nseed: 5\nexperiment: toy.yaml\n"
         "override: {repeats: 1, methods: [default, bo_pso], budget: {flights: 4}}\n"
         "stages: [{name: coarse}, {name: fine, start_from: coarse}]\n"
         "validation: {flights: 2}\n";
  const fs::path out = dir / "out";
  // Not a terminal: one info line per stage and finished trial, each with the ETA.
  ASSERT_EQ(RunQuadtune("--log-level debug study " + (dir / "study.yaml").string() + " --out " +
                            out.string() + " --no-plot --threads 2",
                        dir / "study.log"),
            0)
      << ReadText(dir / "study.log");
  const std::string log = ReadText(dir / "study.log");
  const auto progress = LinesWith(log, "point 1/1");
  ASSERT_GE(progress.size(), 4u) << log;  // two stages of two trials, then validation
  for (const auto& line : progress) EXPECT_NE(line.find(", ETA "), std::string::npos) << line;
  EXPECT_FALSE(LinesWith(log, "stage fine").empty()) << log;
  EXPECT_FALSE(LinesWith(log, "validation flights 6/6").empty()) << log;  // 2 × (2 tuned + 1)
  // The estimator placed every report in the study's plan: per stage 4 + 4 flights, then the
  // 6 validation flights, all counted done at the end. Reports from the two worker threads may
  // reach the log out of order, so the final one is looked for among them, not at the end.
  const auto estimates = LinesWith(log, "eta: at ");
  ASSERT_FALSE(estimates.empty()) << log;
  EXPECT_FALSE(LinesWith(log, "flights 22 of 22 planned").empty()) << log;
  EXPECT_TRUE(LinesWith(log, "flights 23 of").empty()) << log;
  EXPECT_FALSE(LinesWith(log, "ETA 0 s").empty()) << log;
  EXPECT_TRUE(fs::exists(out / "study.json"));
  EXPECT_FALSE(fs::exists(out / "report.html"));
}

}  // namespace
}  // namespace quadtune
