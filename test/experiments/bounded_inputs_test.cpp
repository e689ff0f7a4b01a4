// Hostile inputs and signals through the `quadtune` program, under bounds this harness enforces.
// - Refusals (alias bombs, huge mappings, runaway sizes, free text its outputs would misread):
//   exit 2 and one line on stderr naming the file (or option), the key, the value and the limit,
//   within kDeadlineS seconds (the child is killed past it), a peak resident memory under
//   kPeakRssMib, in an address space of kAddressSpaceMib. Without the bound in the code a case
//   runs on (alias expansion, a quadratic check, a runaway allocation) or says something else.
// - Signals: SIGTERM deep in a long loop ends the program with exit 130 within kSignalDeadlineS.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "../bounded_run.hpp"
#include "../cli_util.hpp"

namespace quadtune::test {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr double kDeadlineS = 2.0;
/// Saved layouts of 8–18 MB are read to the cap before they are refused (0.9–1.0 s on an idle
/// 2-core machine): their bound leaves room for a loaded CI machine running tests side by side.
constexpr double kLargeFileDeadlineS = 8.0;
constexpr long kPeakRssMib = 200;
constexpr long kAddressSpaceMib = 4096;

/// The "billion laughs" shape as one flow list: nine levels, each nine aliases of the one
/// before (9^9 strings once expanded).
std::string AliasBomb() {
  std::string s = "[&l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]";
  for (int level = 1; level <= 8; ++level) {
    s += ", &l" + std::to_string(level) + " [";
    for (int i = 0; i < 9; ++i) s += (i ? ", *l" : "*l") + std::to_string(level - 1);
    s += "]";
  }
  return s + "]";
}

/// A fresh folder holding the toy experiment as toy.yaml.
fs::path CaseDir(const std::string& name) {
  const fs::path dir = FreshTempDir("qt_bounded_" + name + "_" + std::to_string(::getpid()));
  fs::copy_file(ToyExperimentFile(), dir / "toy.yaml");
  return dir;
}

void Write(const fs::path& file, const std::string& text) { std::ofstream(file) << text; }

/// Runs `args` under the bounds; the refusal must be prompt, small, exit 2 and one stderr line
/// holding every `expect`.
void ExpectBoundedRefusal(const std::vector<std::string>& args, const fs::path& dir,
                          const std::vector<std::string>& expect, double deadline_s = kDeadlineS) {
  BoundedChild child(args, dir / "log", kAddressSpaceMib);
  const BoundedResult r = child.Wait(deadline_s);
  EXPECT_FALSE(r.killed_at_deadline) << "still running after " << deadline_s << " s";
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_LT(r.seconds, deadline_s);
  EXPECT_LT(r.peak_rss_mib, kPeakRssMib);
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  for (const auto& e : expect) EXPECT_THAT(r.err, HasSubstr(e));
  EXPECT_FALSE(fs::exists(dir / "out" / "results.sqlite"));
}

TEST(BoundedParsing, AliasBombInAnExperimentFileIsRefused) {
  const fs::path dir = CaseDir("alias_file");
  Write(dir / "bomb.yaml", ReadText(dir / "toy.yaml") + "laughs: " + AliasBomb() + "\n");
  ExpectBoundedRefusal({"run", (dir / "bomb.yaml").string(), "--out", (dir / "out").string(),
                        "--no-plot", "--quiet"},
                       dir, {"bomb.yaml: laughs.1.0: an alias (*name)", "anchors and aliases"});
}

TEST(BoundedParsing, AliasBombThroughSetIsRefused) {
  const fs::path dir = CaseDir("alias_set");
  ExpectBoundedRefusal({"run", (dir / "toy.yaml").string(), "--set", "laughs=" + AliasBomb(),
                        "--out", (dir / "out").string(), "--no-plot", "--quiet"},
                       dir, {"toy.yaml: --set laughs.1.0: an alias (*name)"});
}

TEST(BoundedParsing, AliasBombInAStudyOverrideIsRefused) {
  const fs::path dir = CaseDir("alias_study");
  Write(dir / "study.yaml", "name: st\nseed: 4\nexperiment: toy.yaml\noverride: {laughs: " +
                                AliasBomb() +
                                "}\nsweep: {key: planner.toy.gates, values: [2, 4]}\n");
  ExpectBoundedRefusal({"study", (dir / "study.yaml").string(), "--out", (dir / "out").string(),
                        "--no-plot", "--quiet"},
                       dir, {"study.yaml: override.laughs.1.0: an alias (*name)"});
}

TEST(BoundedParsing, AHundredThousandKeyMappingIsRefused) {
  const fs::path dir = CaseDir("keys");
  std::string text = ReadText(dir / "toy.yaml") + "many:\n";
  for (int i = 0; i < 100000; ++i) text += "  k" + std::to_string(i) + ": 1\n";
  Write(dir / "keys.yaml", text);
  ExpectBoundedRefusal({"run", (dir / "keys.yaml").string(), "--out", (dir / "out").string(),
                        "--no-plot", "--quiet"},
                       dir, {"keys.yaml: many: more than 1000 keys in one mapping (line"});
}

// ---- limits checked before any work ----

TEST(BoundedSizes, ASweepPastItsFlightsOrResolvesIsRefusedWithoutOverflow) {
  const fs::path dir = CaseDir("sweep");
  const std::string toy = (dir / "toy.yaml").string();
  const std::string out = (dir / "out").string();
  // 1048576 × (4 + 2) × 1000 flights overflows an int.
  ExpectBoundedRefusal({"sweep", toy, "--points", "1048576", "--maps", "1000", "--queries",
                        "1048576", "--out", out, "--no-plot", "--quiet"},
                       dir,
                       {"--points: got 1048576: 1048576 × (4 parameters + 2) × --maps 1000 = "
                        "6291456000 flights per layout; at most 1000000"});
  ExpectBoundedRefusal({"sweep", toy, "--points", "100000", "--maps", "1", "--queries", "1048576",
                        "--out", out, "--no-plot", "--quiet"},
                       dir, {"--queries 1048576 = 629145600000 re-solves per layout; at most 10000000"});
  EXPECT_FALSE(fs::exists(out));
}

TEST(BoundedSizes, BenchCountsHaveCeilings) {
  const fs::path dir = CaseDir("bench");
  const std::string toy = (dir / "toy.yaml").string();
  ExpectBoundedRefusal({"bench", toy, "--flights", "-1"}, dir,
                       {"--flights: got '-1'; allowed: an integer in [1, 100000]"});
  ExpectBoundedRefusal({"bench", toy, "--max-threads", "0"}, dir,
                       {"--max-threads: got '0'; allowed: an integer in [1, 256]"});
  ExpectBoundedRefusal({"bench", toy, "--max-threads", "1000000"}, dir,
                       {"--max-threads: got '1000000'; allowed: an integer in [1, 256]"});
  ExpectBoundedRefusal({"bench", toy, "--soak", "10000000", "--max-threads", "1024"}, dir,
                       {"--max-threads: got '1024'; allowed: an integer in [1, 256]"});
  ExpectBoundedRefusal({"bench", toy, "--soak", "10000001"}, dir,
                       {"--soak: got '10000001'; allowed: an integer in [1, 10000000]"});
  ExpectBoundedRefusal({"bench", toy, "--resolves", "1000000000"}, dir,
                       {"--resolves: got '1000000000'; allowed: an integer in [1, 1000000]"});
}

TEST(BoundedSizes, ThreadsPastTheAddressSpaceAreRefusedNotAborted) {
  // kAddressSpaceMib (4096) fits (4096 - 512) / 20 = 179 worker threads.
  const fs::path dir = CaseDir("threads");
  ExpectBoundedRefusal({"run", (dir / "toy.yaml").string(), "--threads", "600", "--out",
                        (dir / "out").string(), "--no-plot", "--quiet"},
                       dir, {"--threads: got 600 threads; at most 179 fit", "ulimit -v 4194304"});
  ExpectBoundedRefusal({"sweep", (dir / "toy.yaml").string(), "--threads", "600", "--out",
                        (dir / "out").string(), "--no-plot", "--quiet"},
                       dir, {"--threads: got 600 threads; at most 179 fit"});
  EXPECT_FALSE(fs::exists(dir / "out"));
}

/// A saved layout of `cylinders` and `rings` obstacles, one flow mapping each.
std::string SavedLayout(int cylinders, int rings) {
  std::string s = "format: quadtune.layout/1\nobstacles:\n  cylinders:\n";
  for (int i = 0; i < cylinders; ++i) {
    s.append("    - {center: [").append(std::to_string(i)).append(", 0], radius: 0.1, z_min: 0, "
                                                                 "z_max: 1}\n");
  }
  s += "  rings:\n";
  for (int i = 0; i < rings; ++i) {
    s.append("    - {center: [").append(std::to_string(i)).append(", 0, 1], yaw: 0, radius: 0.5, "
                                                                 "thickness: 0.1}\n");
  }
  return s;
}

TEST(BoundedSizes, ASavedLayoutPastTheObstacleCapIsRefusedWhileParsed) {
  const fs::path dir = CaseDir("layout");
  Write(dir / "l300k.yaml", SavedLayout(300000, 0));
  ExpectBoundedRefusal({"fly", "--layout", (dir / "l300k.yaml").string(), "--out",
                        (dir / "out").string(), "--no-plot"},
                       dir, {"l300k.yaml: obstacles.cylinders: more than 100000 entries in one list"},
                       kLargeFileDeadlineS);
  Write(dir / "l120k.yaml", SavedLayout(60000, 60000));
  ExpectBoundedRefusal({"fly", "--layout", (dir / "l120k.yaml").string(), "--out",
                        (dir / "out").string(), "--no-plot"},
                       dir, {"l120k.yaml: obstacles.rings.", "more than 1210000 values",
                             "at most 100000 obstacles"},
                       kLargeFileDeadlineS);
  // Few values each, but more obstacles than the cap: counted before any obstacle is read.
  std::string empty = "format: quadtune.layout/1\nobstacles:\n  cylinders:\n";
  for (int i = 0; i < 60000; ++i) empty += "    - {}\n";
  Write(dir / "empty.yaml", empty + "  rings:\n" + empty.substr(empty.find("    - {}")));
  ExpectBoundedRefusal({"fly", "--layout", (dir / "empty.yaml").string(), "--out",
                        (dir / "out").string(), "--no-plot"},
                       dir, {"empty.yaml: obstacles.cylinders: 60000 cylinders + 60000 rings = "
                             "120000 obstacles; a layout holds at most 100000"});
  EXPECT_FALSE(fs::exists(dir / "out"));
}

// ---- prompt cancellation: exit 130 within kSignalDeadlineS of SIGTERM ----

constexpr double kSignalDeadlineS = 1.0;

/// Starts `args`, waits `after_s` seconds for it to be deep in its work, sends SIGTERM and
/// expects exit 130 within kSignalDeadlineS.
BoundedResult ExpectPromptStop(const std::vector<std::string>& args, const fs::path& dir,
                               double after_s) {
  BoundedChild child(args, dir / "log", kAddressSpaceMib);
  std::this_thread::sleep_for(std::chrono::duration<double>(after_s));
  EXPECT_TRUE(child.Running()) << "ended before the signal: " << ReadText(dir / "log.err");
  child.Signal(SIGTERM);
  const BoundedResult r = child.Wait(kSignalDeadlineS);
  EXPECT_FALSE(r.killed_at_deadline) << "still running " << kSignalDeadlineS << " s after SIGTERM";
  EXPECT_EQ(r.exit_code, 130) << r.err;
  return r;
}

TEST(PromptCancellation, ALongShortTermEvaluationStopsOnSigterm) {
  // One generation of bo_pso re-solves 4 × 10 000 queries of about 10 ms on 2 threads: 200 s.
  const fs::path dir = CaseDir("short_term");
  Write(dir / "slow.yaml",
        "name: slow\nseed: 2\nthreads: 2\nmode: reproducible\nrepeats: 1\nmethods: [bo_pso]\n"
        "planner:\n  type: sleep\n  sleep: {resolve_median_s: 0.01, resolve_p95_s: 0.02,"
        " flight_median_s: 0.01, flight_p95_s: 0.02, queries_per_flight: 10}\n"
        "parameters:\n  - {name: effort, lower: 0.25, upper: 4.0, default: 1.0}\n"
        "  - {name: pace, lower: 0.5, upper: 4.0, default: 1.0}\n"
        "short_term: [effort]\nlong_term: [pace]\n"
        "budget: {flights: 4, flight_batch: 1, short_evals_per_flight: 100000,"
        " queries_per_eval: 10000}\n"
        "pso: {num_particles: 4}\nbo: {initial_design_size: 2, acquisition_pool: 100}\n");
  const BoundedResult r = ExpectPromptStop(
      {"run", (dir / "slow.yaml").string(), "--out", (dir / "out").string(), "--no-plot",
       "--quiet"},
      dir, 2.0);
  EXPECT_THAT(r.err, HasSubstr("--resume"));
  EXPECT_TRUE(fs::exists(dir / "out" / "results.sqlite"));
}

TEST(PromptCancellation, LayoutGenerationStopsOnSigtermWithExit130) {
  // About 53 000 obstacles: generation takes seconds.
  const fs::path dir = CaseDir("layout_signal");
  Write(dir / "big.yaml",
        "region: {min: [0.0, -300.0], max: [600.0, 300.0]}\n"
        "mission: {start: [0.0, 0.0, 1.2], goal: [600.0, 0.0, 1.2], keep_out_radius: 1.5}\n"
        "spacing: 1.3\ndensity: area\nmin_gap: 0.2\n"
        "obstacles:\n  ring_fraction: 0.1\n  cylinder: {radius: [0.125, 0.4], height: [3.0, 3.0]}\n"
        "  ring: {radius: [0.7, 1.0], thickness: [0.1, 0.15], center_height: [1.2, 1.6],"
        " yaw: [-0.3, 0.3]}\n");
  const BoundedResult r = ExpectPromptStop(
      {"layout", "--layout-options", (dir / "big.yaml").string(), "--out",
       (dir / "l.yaml").string()},
      dir, 1.0);
  EXPECT_THAT(r.err, HasSubstr("layout generation interrupted; nothing written"));
  EXPECT_FALSE(fs::exists(dir / "l.yaml"));
}

TEST(PromptCancellation, ALongSoakStopsOnSigtermWithFlatMemory) {
  // Ten million toy flights: the queue holds one task per thread, so memory stays small.
  const fs::path dir = CaseDir("soak");
  const BoundedResult r = ExpectPromptStop(
      {"bench", (dir / "toy.yaml").string(), "--soak", "10000000", "--max-threads", "2"}, dir,
      1.0);
  EXPECT_THAT(r.err, HasSubstr("soak interrupted after"));
  EXPECT_LT(r.peak_rss_mib, kPeakRssMib);
}

// ---- free text checked for where it goes ----

TEST(FreeText, ANulByteInATextValueIsRefused) {
  const fs::path dir = CaseDir("nul");
  const std::string toy = ReadText(dir / "toy.yaml");
  Write(dir / "nul.yaml", "name: \"to\\0y\"\n" + toy.substr(toy.find("seed:")));
  ExpectBoundedRefusal({"run", (dir / "nul.yaml").string(), "--out", (dir / "out").string(),
                        "--no-plot", "--quiet"},
                       dir, {"nul.yaml: name: the text holds a NUL byte (\\0) at offset 2"});
  ExpectBoundedRefusal({"run", (dir / "toy.yaml").string(), "--set", "name=\"a\\0\"", "--out",
                        (dir / "out").string(), "--no-plot", "--quiet"},
                       dir, {"toy.yaml: name: the text holds a NUL byte"});
}

TEST(FreeText, TheReportsEmbeddedDataEscapesEveryAngleBracket) {
  const fs::path dir = CaseDir("report_json");
  const fs::path out = dir / "out";
  ASSERT_EQ(RunQuadtune("run " + (dir / "toy.yaml").string() +
                            " --set 'name=\"<!--<script>x</script>\"' --set budget.flights=2"
                            " --set repeats=1 --out " + out.string() + " --no-plot --quiet",
                        dir / "run.log"),
            0)
      << ReadText(dir / "run.log");
  ASSERT_EQ(RunQuadtune("report " + out.string(), dir / "report.log"), 0)
      << ReadText(dir / "report.log");
  const std::string page = ReadText(out / "report.html");
  const std::string open = "id=\"qt-data\">";
  const auto begin = page.find(open);
  ASSERT_NE(begin, std::string::npos);
  const auto end = page.find("</script>", begin);
  ASSERT_NE(end, std::string::npos);
  const std::string data = page.substr(begin + open.size(), end - begin - open.size());
  EXPECT_EQ(data.find('<'), std::string::npos) << "a '<' in the embedded data";
  EXPECT_THAT(data, HasSubstr("\\u003c!--\\u003cscript\\u003ex\\u003c/script\\u003e"));
}

TEST(FreeText, StudyLabelsThatOutputsWouldReadAsMarkupOrFormulasAreRefused) {
  const fs::path dir = CaseDir("labels");
  const auto study = [&](const std::string& labels) {
    Write(dir / "study.yaml", "name: st\nseed: 4\nexperiment: toy.yaml\n"
                              "sweep: {key: planner.toy.gates, values: [2, 4], labels: " +
                                  labels + "}\n");
    return std::vector<std::string>{"study", (dir / "study.yaml").string(), "--out",
                                    (dir / "out").string(), "--no-plot", "--quiet"};
  };
  ExpectBoundedRefusal(study("['$\\foo$', b]"), dir,
                       {"study.yaml: sweep.labels.0: '$\\foo$' holds '$'", "plain text"});
  ExpectBoundedRefusal(study("[a, '=HYPERLINK(\"http://x\")']"), dir,
                       {"sweep.labels.1: '=HYPERLINK(\"http://x\")' starts with '='"});
  ExpectBoundedRefusal(study("[a, '<b>']"), dir, {"sweep.labels.1: '<b>' holds '<'"});
  ExpectBoundedRefusal(study("[a, 'x|y']"), dir, {"sweep.labels.1: 'x|y' holds '|'"});
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(FreeText, StudyResumeOfAFolderWithoutAStudyIsRefused) {
  const fs::path dir = CaseDir("study_resume");
  Write(dir / "study.yaml", "name: st\nseed: 4\nexperiment: toy.yaml\n"
                            "sweep: {key: planner.toy.gates, values: [2, 4]}\n");
  ExpectBoundedRefusal({"study", (dir / "study.yaml").string(), "--out", (dir / "out").string(),
                        "--resume", "--no-plot", "--quiet"},
                       dir, {"out: --resume: holds no study to continue"});
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(FreeText, ANegativeSweepSeedIsRefusedInOneShortLine) {
  const fs::path dir = CaseDir("seed");
  BoundedChild child({"sweep", (dir / "toy.yaml").string(), "--seed", "-1", "--out",
                      (dir / "out").string()},
                     dir / "log", kAddressSpaceMib);
  const BoundedResult r = child.Wait(kDeadlineS);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_THAT(r.err, HasSubstr("--seed: a seed is a decimal integer >= 0, got '-1'"));
  EXPECT_LT(r.err.size(), 120u) << r.err;
}

TEST(FreeText, ADirectoryGivenAsAPlannerFileNamesTheFileAndKey) {
  const fs::path dir = CaseDir("dir_as_file");
  fs::create_directories(dir / "d.yaml");
  const std::string tiny = std::string(QUADTUNE_SOURCE_DIR) + "/experiments/tiny.yaml";
  ExpectBoundedRefusal({"run", tiny, "--set", "planner.drone=" + (dir / "d.yaml").string(),
                        "--out", (dir / "out").string(), "--no-plot", "--quiet"},
                       dir, {"tiny.yaml: planner.drone: '" + (dir / "d.yaml").string() +
                             "' is a directory; expected a file"});
  ExpectBoundedRefusal({"run", tiny, "--set", "planner.layout=null", "--set",
                        "planner.layout_file=" + (dir / "d.yaml").string(), "--out",
                        (dir / "out").string(), "--no-plot", "--quiet"},
                       dir, {"tiny.yaml: planner.layout_file: '" + (dir / "d.yaml").string() +
                             "' is a directory; expected a file"});
}

TEST(FreeText, ASavedLayoutGivenAsLayoutOptionsIsNamedAsSuch) {
  const fs::path dir = CaseDir("saved_as_options");
  const std::string saved =
      std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/forest_1p3_seed1.layout.yaml";
  ExpectBoundedRefusal({"run", std::string(QUADTUNE_SOURCE_DIR) + "/experiments/tiny.yaml", "--set",
                        "planner.layout=null", "--set", "planner.layout_file=" + saved, "--out",
                        (dir / "out").string(), "--no-plot", "--quiet"},
                       dir, {"forest_1p3_seed1.layout.yaml: is a saved layout (written by "
                             "`quadtune layout`), not layout generator options"});
  ExpectBoundedRefusal({"layout", "--layout-options", saved, "--out", (dir / "l.yaml").string()},
                       dir, {"is a saved layout", "quadtune fly --layout FILE"});
}

TEST(PromptCancellation, AFlightStopsOnSigtermAndWritesNothing) {
  // 360 s of simulated flight at 0.3 m/s along the 48 m corridor: about 3 s of wall time.
  const fs::path dir = CaseDir("fly");
  const std::string corridor = std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/changing_density_thin.yaml";
  const BoundedResult r = ExpectPromptStop(
      {"fly", "--layout-options", corridor, "--seed", "1", "--out", (dir / "out").string(),
       "--set", "v_des=0.3", "--max-time", "3000", "--no-plot"},
      dir, 0.8);
  EXPECT_THAT(r.err, HasSubstr("fly interrupted; nothing written"));
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(PromptCancellation, AnAdaptRunStopsOnSigtermAndWritesNoFlight) {
  // Five flights one after another, four of them 0.3 m/s baselines along the 48 m corridor
  // (about 0.7 s of wall time each).
  const fs::path dir = CaseDir("adapt");
  const BoundedResult r = ExpectPromptStop(
      {"adapt", std::string(QUADTUNE_SOURCE_DIR) + "/experiments/changing_environment.yaml",
       "--out", (dir / "out").string(), "--no-plot", "--threads", "1", "--set",
       "baselines=[0.3, 0.31, 0.32, 0.33]", "--set", "max_time=1000"},
      dir, 0.8);
  EXPECT_THAT(r.err, HasSubstr("adapt interrupted; no flight written"));
  EXPECT_FALSE(fs::exists(dir / "out" / "summary.json"));
  EXPECT_FALSE(fs::exists(dir / "out" / "adapted"));
}

TEST(PromptCancellation, AnInterruptedSweepResumesToTheSameResult) {
  // 80 flights of 0.05 s each (toy planner) and their re-solves, on 2 threads: about 2.5 s.
  const fs::path dir = CaseDir("sweep_resume");
  const std::vector<std::string> sweep = {"sweep", (dir / "toy.yaml").string(), "--points", "8",
                                          "--maps", "2", "--no-plot", "--quiet", "--set",
                                          "planner.toy.flight_delay_s=0.05"};
  auto with = [&](const std::string& out, std::vector<std::string> more) {
    std::vector<std::string> args = sweep;
    args.push_back("--out");
    args.push_back(out);
    args.insert(args.end(), more.begin(), more.end());
    return args;
  };
  const std::string full = (dir / "full").string();
  const std::string cut = (dir / "cut").string();
  BoundedChild whole(with(full, {}), dir / "full_log", kAddressSpaceMib);
  ASSERT_EQ(whole.Wait(60.0).exit_code, 0);
  const BoundedResult r = ExpectPromptStop(with(cut, {}), dir, 0.8);
  EXPECT_THAT(r.err, HasSubstr("continue with the same command and --resume"));
  ASSERT_TRUE(fs::exists(fs::path(cut) / "sweep.journal"));
  EXPECT_FALSE(fs::exists(fs::path(cut) / "points.csv"));
  BoundedChild resumed(with(cut, {"--resume"}), dir / "resumed_log", kAddressSpaceMib);
  const BoundedResult rr = resumed.Wait(60.0);
  ASSERT_EQ(rr.exit_code, 0) << rr.err;
  for (const char* file : {"points.csv", "sweep.csv", "indices.csv"}) {
    EXPECT_EQ(ReadText(fs::path(cut) / file), ReadText(fs::path(full) / file)) << file;
  }
  EXPECT_FALSE(fs::exists(fs::path(cut) / "sweep.journal"));
}

TEST(DamagedStores, ExportPlotAndThePythonReaderNameTheFileTheRowAndTheColumn) {
  const fs::path dir = CaseDir("damaged_store");
  const fs::path out = dir / "out";
  ASSERT_EQ(RunQuadtune("--log-level warn run --no-plot --quiet " + (dir / "toy.yaml").string() +
                            " --out " + out.string() + " --set 'methods=[default, random]'",
                        dir / "run.log"),
            0)
      << ReadText(dir / "run.log");
  const std::string store = (out / "results.sqlite").string();
  ASSERT_EQ(std::system(("sqlite3 '" + store + "' \"UPDATE evaluation SET params = '{broken' "
                         "WHERE id = 5\"").c_str()),
            0);
  EXPECT_EQ(RunQuadtune("export " + store + " --tidy " + (dir / "tidy").string(),
                        dir / "export.log"),
            2);
  EXPECT_THAT(ReadText(dir / "export.log"),
              HasSubstr(store + ": evaluation 5: params: damaged results store: not a JSON object"));
  EXPECT_FALSE(fs::exists(dir / "tidy"));
  ASSERT_EQ(RunQuadtune("plot run " + out.string(), dir / "plot.log"), 1);
  EXPECT_THAT(ReadText(dir / "plot.log"),
              HasSubstr(store + ": damaged results store: evaluation 5: params is not JSON"));
  const std::string python = "PYTHONPATH='" + std::string(QUADTUNE_SOURCE_DIR) +
                             "/experiments/python' /usr/bin/python3 -c \"import quadtune; "
                             "quadtune.load('" + out.string() + "')\" > '" +
                             (dir / "py.log").string() + "' 2>&1";
  EXPECT_NE(std::system(python.c_str()), 0);
  EXPECT_THAT(ReadText(dir / "py.log"),
              HasSubstr("quadtune.DamagedStore: " + store +
                        ": damaged results store: evaluation 5: params is not JSON"));
  // A seed no flight can have (pandas would raise OverflowError on it).
  ASSERT_EQ(std::system(("sqlite3 '" + store + "' \"UPDATE evaluation SET params = '{}', "
                         "map_seed = '-5' WHERE id = 5\"").c_str()),
            0);
  EXPECT_NE(std::system(python.c_str()), 0);
  EXPECT_THAT(ReadText(dir / "py.log"),
              HasSubstr(store + ": damaged results store: evaluation 5: map_seed is '-5', not a "
                                "seed"));
  // A file that is no store at all.
  Write(dir / "junk.sqlite", "not a database, just text\n");
  const std::string junk = "PYTHONPATH='" + std::string(QUADTUNE_SOURCE_DIR) +
                           "/experiments/python' /usr/bin/python3 -c \"import quadtune; "
                           "quadtune.load('" + (dir / "junk.sqlite").string() + "')\" > '" +
                           (dir / "junk.log").string() + "' 2>&1";
  EXPECT_NE(std::system(junk.c_str()), 0);
  EXPECT_THAT(ReadText(dir / "junk.log"), HasSubstr("junk.sqlite: not a readable quadtune results "
                                                    "store (file is not a database)"));
}

TEST(Writers, ExportOfAFileThatIsNotAStoreWritesNothing) {
  const fs::path dir = CaseDir("export");
  ExpectBoundedRefusal({"export", (dir / "toy.yaml").string(), "--csv", (dir / "csv").string()},
                       dir, {"toy.yaml: the results file is damaged (file is not a database)"});
  EXPECT_FALSE(fs::exists(dir / "csv"));
}

TEST(Writers, AReportIntoADirectoryARunIsWritingIsRefused) {
  const fs::path dir = CaseDir("report_lock");
  const std::string toy = ReadText(dir / "toy.yaml");
  Write(dir / "slow.yaml", toy.substr(0, toy.find("plan_interval: 1.0}")) +
                               "plan_interval: 1.0, flight_delay_s: 0.2}" +
                               toy.substr(toy.find("plan_interval: 1.0}") + 19));
  const fs::path out = dir / "out";
  BoundedChild run({"run", (dir / "slow.yaml").string(), "--out", out.string(), "--no-plot",
                    "--quiet"},
                   dir / "run", kAddressSpaceMib);
  while (run.Running() && ReadText(out / ".quadtune.lock").empty()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  BoundedChild report({"report", out.string()}, dir / "report", kAddressSpaceMib);
  const BoundedResult r = report.Wait(kDeadlineS);
  run.Signal(SIGTERM);
  EXPECT_EQ(run.Wait(30.0).exit_code, 130);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_THAT(r.err, HasSubstr("out: DIR: another quadtune process (pid " +
                               std::to_string(run.pid()) + ") is writing this result directory"));
  EXPECT_FALSE(fs::exists(out / "report.html"));
}

TEST(Writers, AReportThatCannotBeWrittenWholeLeavesNoPage) {
  // A file-size limit stands in for a full disk: the page (megabytes: the JavaScript libraries
  // are inlined) cannot be written whole, so none may be left, and no partial file either.
  const fs::path dir = CaseDir("report_full");
  const fs::path out = dir / "out";
  ASSERT_EQ(RunQuadtune("--log-level warn run --no-plot --quiet " + (dir / "toy.yaml").string() +
                            " --out " + out.string() + " --set 'methods=[default]'",
                        dir / "run.log"),
            0)
      << ReadText(dir / "run.log");
  const std::string cmd = "ulimit -f 256; " + QuadtuneBinary() + " report " + out.string() +
                          " > " + (dir / "report.log").string() + " 2>&1";
  const int status = std::system(("sh -c '" + cmd + "'").c_str());
  EXPECT_EQ(WIFEXITED(status) ? WEXITSTATUS(status) : -1, 1) << ReadText(dir / "report.log");
  EXPECT_THAT(ReadText(dir / "report.log"), HasSubstr("report.html: File too large"));
  EXPECT_FALSE(fs::exists(out / "report.html"));
  EXPECT_FALSE(fs::exists(out / "report.html.partial"));
  // Without the limit the page is written.
  ASSERT_EQ(RunQuadtune("report " + out.string(), dir / "report2.log"), 0)
      << ReadText(dir / "report2.log");
  EXPECT_TRUE(fs::exists(out / "report.html"));
}

}  // namespace
}  // namespace quadtune::test
