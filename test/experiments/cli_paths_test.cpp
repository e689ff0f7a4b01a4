// Paths of the `quadtune` program not covered by the paper experiments: the layout command, fly's
// options (--layout, --drone, --world, --set and its errors, --mission go_to), plot flights, the
// exit codes 1 (an unexpected error), 2 (bad input), 3 (a flight that did not complete) and 130
// (interrupted), study --resume, and the real planner's timeout in a stored evaluation.
// Small scenes and short flights; outputs are checked for content, not only existence.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sqlite3.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "../cli_util.hpp"
#include "../sqlite_util.hpp"
#include "../process_util.hpp"

namespace quadtune {
namespace {

namespace fs = std::filesystem;
using test::QuadtuneBinary;
using test::ReadCsv;
using test::ReadText;
using test::RunQuadtune;
using test::ToyExperimentFile;

const std::string kExperiments = std::string(QUADTUNE_SOURCE_DIR) + "/experiments/";

fs::path Fresh(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("quadtune_cli_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A 10 m × 8 m scene at 3 m spacing (the flight from x = 0 to x = 8 m takes seconds).
const char* kSmallLayoutOptions =
    "region: {min: [-1.0, -4.0], max: [9.0, 4.0]}\n"
    "mission: {start: [0.0, 0.0, 1.2], goal: [8.0, 0.0, 1.2], keep_out_radius: 1.0}\n"
    "spacing: 3.0\n"
    "tolerance: 0.05\n"
    "obstacles: {ring_fraction: 0.0, cylinder: {radius: [0.125, 0.3], height: [3.0, 3.0]}}\n";

nlohmann::json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  if (!in) {
    ADD_FAILURE() << "cannot read " << path;
    return {};
  }
  return nlohmann::json::parse(in);
}

double Num(const std::map<std::string, std::string>& row, const std::string& key) {
  const auto it = row.find(key);
  if (it == row.end()) {
    ADD_FAILURE() << "no column " << key;
    return std::nan("");
  }
  return std::stod(it->second);
}

std::string FirstLine(const fs::path& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

// `quadtune layout`: the saved file holds the generated cylinders; the same seed gives the same
// file, another seed another layout; a bad spacing is refused with exit code 2 and the key.
TEST(CliLayout, SavesAReproducibleLayout) {
  const fs::path dir = Fresh("layout");
  std::ofstream(dir / "options.yaml") << kSmallLayoutOptions;
  auto make = [&](int seed, const std::string& name) {
    const fs::path out = dir / name;
    EXPECT_EQ(RunQuadtune("--log-level warn layout --layout-options " + (dir / "options.yaml").string() +
                              " --seed " + std::to_string(seed) + " --out " + out.string(),
                          dir / "layout.log"),
              0)
        << ReadText(dir / "layout.log");
    return out;
  };
  const fs::path a = make(4, "a.yaml");
  const fs::path again = make(4, "again.yaml");
  const fs::path other = make(5, "other.yaml");
  EXPECT_EQ(ReadText(a), ReadText(again));
  EXPECT_NE(ReadText(a), ReadText(other));
  const YAML::Node layout = YAML::LoadFile(a.string());
  EXPECT_EQ(layout["format"].as<std::string>(), "quadtune.layout/1");
  EXPECT_EQ(layout["seed"].as<int>(), 4);
  EXPECT_DOUBLE_EQ(layout["options"]["spacing"].as<double>(), 3.0);
  const YAML::Node cylinders = layout["obstacles"]["cylinders"];
  ASSERT_TRUE(cylinders.IsSequence());
  // 10 m × 8 m at about 3 m spacing: a few cylinders, all inside the region and clear of start
  // and goal.
  EXPECT_GE(cylinders.size(), 2u);
  for (const auto& c : cylinders) {
    const double x = c["center"][0].as<double>(), y = c["center"][1].as<double>();
    EXPECT_GE(x, -1.0);
    EXPECT_LE(x, 9.0);
    EXPECT_GE(y, -4.0);
    EXPECT_LE(y, 4.0);
    EXPECT_GT(std::hypot(x, y), 1.0);
    EXPECT_GT(std::hypot(x - 8.0, y), 1.0);
  }
  // --spacing without --options; a bad value is refused naming the key.
  EXPECT_EQ(RunQuadtune("--log-level warn layout --spacing -1 --out " + (dir / "bad.yaml").string(),
                        dir / "bad.log"),
            2);
  EXPECT_NE(ReadText(dir / "bad.log").find("spacing"), std::string::npos)
      << ReadText(dir / "bad.log");
  EXPECT_FALSE(fs::exists(dir / "bad.yaml"));
}

// `quadtune fly` through a saved layout, with another drone, a world file, a planner override and
// a go-to mission; then `plot flights` over it and a second flight.
TEST(CliFly, LayoutDroneWorldSetAndGoTo) {
  const fs::path dir = Fresh("fly");
  std::ofstream(dir / "options.yaml") << kSmallLayoutOptions;
  ASSERT_EQ(RunQuadtune("--log-level warn layout --layout-options " + (dir / "options.yaml").string() +
                            " --seed 4 --out " + (dir / "layout.yaml").string(),
                        dir / "layout.log"),
            0)
      << ReadText(dir / "layout.log");
  std::ofstream(dir / "world.yaml") << "wind: [0.3, 0.0, 0.0]\n";
  const fs::path f = dir / "f";
  const int code =
      RunQuadtune("--log-level warn fly --layout " + (dir / "layout.yaml").string() +
                      " --drone drones/agile_small.yaml --world " + (dir / "world.yaml").string() +
                      " --set v_des=1.0 --set h_pl=5.0 --mission go_to --seed 3 --max-time 60 "
                      "--no-plot --out " +
                      f.string(),
                  dir / "fly.log");
  const nlohmann::json summary = ReadJson(f / "summary.json");
  ASSERT_FALSE(summary.is_null()) << ReadText(dir / "fly.log");
  EXPECT_EQ(summary["status"], "completed") << ReadText(dir / "fly.log");
  EXPECT_EQ(code, 0) << ReadText(dir / "fly.log");
  EXPECT_EQ(summary["drone"], "agile_small");
  EXPECT_EQ(summary["seed"], 3);
  // The saved layout was flown: obstacles.json and the copied layout hold its cylinders.
  const YAML::Node layout = YAML::LoadFile((dir / "layout.yaml").string());
  const YAML::Node cylinders = layout["obstacles"]["cylinders"];
  const nlohmann::json obstacles = ReadJson(f / "obstacles.json");
  ASSERT_EQ(obstacles["cylinders"].size(), cylinders.size());
  EXPECT_EQ(summary["obstacles"], cylinders.size());
  for (std::size_t i = 0; i < cylinders.size(); ++i) {
    EXPECT_DOUBLE_EQ(obstacles["cylinders"][i]["x"].get<double>(),
                     cylinders[i]["center"][0].as<double>());
    EXPECT_DOUBLE_EQ(obstacles["cylinders"][i]["y"].get<double>(),
                     cylinders[i]["center"][1].as<double>());
    EXPECT_DOUBLE_EQ(obstacles["cylinders"][i]["radius"].get<double>(),
                     cylinders[i]["radius"].as<double>());
  }
  EXPECT_EQ(ReadText(f / "layout.yaml"), ReadText(dir / "layout.yaml"));
  // go-to: the flight ends at the goal (8, 0, 1.2), not back at the start.
  const auto flight = ReadCsv(f / "flight.csv");
  ASSERT_GT(flight.size(), 10u);
  const auto& last = flight.back();
  EXPECT_LT(std::hypot(Num(last, "x") - 8.0, Num(last, "y")), 0.5);
  EXPECT_NEAR(Num(last, "t"), summary["flight_time"].get<double>(), 0.1);  // logged at 20 Hz
  // v_des = 1.0 (the default is 2.0): the drone never flies much faster.
  EXPECT_LE(summary["max_speed"].get<double>(), 1.0 * 1.3);
  double max_row_speed = 0.0;
  for (const auto& row : flight) {
    max_row_speed = std::max(
        max_row_speed, std::sqrt(Num(row, "vx") * Num(row, "vx") + Num(row, "vy") * Num(row, "vy") +
                                 Num(row, "vz") * Num(row, "vz")));
  }
  EXPECT_LE(max_row_speed, 1.0 * 1.3);
  // plans.csv: its columns, samples of every plan counted in the summary, in time order.
  EXPECT_EQ(FirstLine(f / "plans.csv"), "plan,t0,t,x,y,z,vx,vy,vz");
  const auto plans = ReadCsv(f / "plans.csv");
  ASSERT_FALSE(plans.empty());
  int last_plan = -1;
  for (const auto& row : plans) {
    const int plan = static_cast<int>(Num(row, "plan"));
    EXPECT_GE(plan, last_plan);
    last_plan = plan;
    EXPECT_GE(Num(row, "t"), Num(row, "t0") - 1e-9);
  }
  EXPECT_GE(last_plan + 1, 1);
  EXPECT_LE(last_plan + 1, summary["plans"].get<int>());

  // A second flight (the default drone and mission at 3 m spacing), then the summary figures.
  const fs::path g = dir / "g";
  ASSERT_EQ(
      RunQuadtune(
          "--log-level warn fly --spacing 3.0 --seed 2 --no-plot --max-time 60 --out " + g.string(),
          dir / "fly2.log"),
      0)
      << ReadText(dir / "fly2.log");
  const fs::path plots = dir / "plots";
  ASSERT_EQ(
      RunQuadtune("plot flights " + f.string() + " " + g.string() + " --out " + plots.string(),
                  dir / "plot.log"),
      0)
      << ReadText(dir / "plot.log");
  for (const char* png : {"flights_topdown.png", "flight_time_vs_spacing.png"}) {
    EXPECT_GT(fs::file_size(plots / png), 10000u) << png;
  }
  // The table: a header, a rule and one row per flight with its status and flight time.
  const std::string table = ReadText(plots / "flights.md");
  int rows = 0;
  for (std::size_t pos = 0; (pos = table.find("| completed |", pos)) != std::string::npos; ++pos) {
    ++rows;
  }
  EXPECT_EQ(rows, 2) << table;
  char t_f[32];
  std::snprintf(t_f, sizeof t_f, "| %.2f |", summary["flight_time"].get<double>());
  EXPECT_NE(table.find(t_f), std::string::npos) << table;
}

// fly --set: every malformed override is refused before flying, with exit code 2, naming what is
// wrong; a bad --world file names its key; --planner takes the registry's closed-loop types.
TEST(CliFly, SetAndWorldErrors) {
  const fs::path dir = Fresh("fly_errors");
  struct Case {
    std::string args;
    std::string words;
  };
  std::ofstream(dir / "world.yaml") << "wind: [0.3, 0.0, 0.0]\nwindd: 1\n";
  const std::vector<Case> cases = {
      {"--set v_des", "NAME=VALUE"},
      {"--set v_des=fast", "'fast' is not a number"},
      {"--set v_des=2x", "'2x' is not a number"},
      {"--set no_such_parameter=1", "no_such_parameter"},
      {"--set v_des=-1", "v_des"},
      {"--world " + (dir / "world.yaml").string(), "windd"},
      {"--planner toy", "'toy' is not a registered planner flown in the closed loop"},
      {"--planner rrt", "registered: ego, ipopt"},
  };
  int k = 0;
  for (const auto& c : cases) {
    const fs::path out = dir / ("out" + std::to_string(k));
    const fs::path log = dir / ("log" + std::to_string(k++));
    EXPECT_EQ(
        RunQuadtune("fly --spacing 3.0 --max-time 1 --no-plot " + c.args + " --out " + out.string(),
                    log),
        2)
        << c.args << ": " << ReadText(log);
    EXPECT_NE(ReadText(log).find(c.words), std::string::npos) << c.args << ": " << ReadText(log);
    EXPECT_FALSE(fs::exists(out / "summary.json")) << c.args;
  }
}

// A flight cut by --max-time: exit code 3 and the status in summary.json.
TEST(CliFly, TimeoutIsExitCodeThreeAndRecorded) {
  const fs::path dir = Fresh("fly_timeout");
  EXPECT_EQ(
      RunQuadtune("--log-level warn fly --spacing 3.0 --seed 2 --max-time 2 --no-plot --out " +
                      (dir / "f").string(),
                  dir / "fly.log"),
      3)
      << ReadText(dir / "fly.log");
  const nlohmann::json summary = ReadJson(dir / "f" / "summary.json");
  EXPECT_EQ(summary["status"], "timeout");
  EXPECT_NEAR(summary["flight_time"].get<double>(), 2.0, 0.1);
}

// The real (Ipopt) planner's flights cut by max_time are stored as evaluations whose message
// names the timeout and whose value is the failure value; the run completes its budget.
TEST(CliRun, RealPlannerTimeoutsAreStoredRows) {
  const fs::path dir = Fresh("run_timeout");
  const fs::path out = dir / "run";
  ASSERT_EQ(RunQuadtune("--log-level warn run --no-plot " + kExperiments + "tiny.yaml --out " +
                            out.string() +
                            " --quiet --set planner.max_time=2 --set 'methods=[random]' "
                            "--set budget.flights=2",
                        dir / "run.log"),
            0)
      << ReadText(dir / "run.log");
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open_v2((out / "results.sqlite").c_str(), &db, SQLITE_OPEN_READONLY, nullptr),
            SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db,
                               "SELECT status, message, value FROM evaluation WHERE kind = "
                               "'long'",
                               -1, &st, nullptr),
            SQLITE_OK);
  int rows = 0;
  while (sqlite3_step(st) == SQLITE_ROW) {
    ++rows;
    const std::string message = reinterpret_cast<const char*>(sqlite3_column_text(st, 1));
    EXPECT_EQ(message.rfind("timeout", 0), 0u) << message;
    // A flight that did not finish scores the experiment's failure_value (tiny.yaml: 1000).
    EXPECT_EQ(sqlite3_column_double(st, 2), 1000.0);
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  EXPECT_EQ(rows, 2);
  // The export carries the same rows.
  ASSERT_EQ(RunQuadtune("--log-level warn export " + (out / "results.sqlite").string() + " --csv " +
                            (dir / "csv").string(),
                        dir / "export.log"),
            0);
  // (Its params column is quoted JSON with commas: count the lines.)
  std::ifstream csv(dir / "csv" / "evaluations.csv");
  int exported = 0;
  for (std::string line; std::getline(csv, line);) {
    exported += line.find(",long,") != std::string::npos &&
                line.find("timeout: mission not finished") != std::string::npos;
  }
  EXPECT_EQ(exported, 2);
}

// Exit code 1: an error that is not bad configuration (here a results file that is not SQLite);
// exit code 2 for a results file that does not exist.
TEST(CliExitCodes, UnexpectedErrorIsOneMissingInputIsTwo) {
  const fs::path dir = Fresh("exit_codes");
  // A file that is not a store is bad input (2), named with what is wrong with it.
  std::ofstream(dir / "garbage.sqlite") << "this is not a database, just text long enough to "
                                           "fill a page header of sixteen bytes or more\n";
  EXPECT_EQ(RunQuadtune(
                "export " + (dir / "garbage.sqlite").string() + " --csv " + (dir / "csv").string(),
                dir / "garbage.log"),
            2)
      << ReadText(dir / "garbage.log");
  EXPECT_NE(ReadText(dir / "garbage.log").find("garbage.sqlite: the results file is damaged"),
            std::string::npos)
      << ReadText(dir / "garbage.log");
  // A path that cannot be written while working is an error while running (1).
  ASSERT_EQ(RunQuadtune("run --no-plot --quiet " + ToyExperimentFile() + " --out " +
                            (dir / "small").string() + " --set budget.flights=2",
                        dir / "small.log"),
            0)
      << ReadText(dir / "small.log");
  std::ofstream(dir / "blocker") << "a file where a folder should be\n";
  EXPECT_EQ(RunQuadtune("export " + (dir / "small" / "results.sqlite").string() + " --csv " +
                            (dir / "blocker" / "csv").string(),
                        dir / "blocked.log"),
            1)
      << ReadText(dir / "blocked.log");
  EXPECT_EQ(
      RunQuadtune("export " + (dir / "none.sqlite").string() + " --csv " + (dir / "csv").string(),
                  dir / "none.log"),
      2)
      << ReadText(dir / "none.log");
  EXPECT_NE(ReadText(dir / "none.log").find("no such results file"), std::string::npos);
  // run --resume without a store: bad input, nothing created.
  EXPECT_EQ(RunQuadtune("run " + ToyExperimentFile() + " --out " + (dir / "fresh").string() +
                            " --resume --quiet",
                        dir / "resume.log"),
            2)
      << ReadText(dir / "resume.log");
  EXPECT_NE(ReadText(dir / "resume.log").find("--resume"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "fresh" / "results.sqlite"));
}

int CountRows(const fs::path& store) { return test::CountEvaluations(store.string()); }

// The toy experiment with a delay per flight, so a run can be interrupted part-way.
std::string SlowToy() {
  std::string text = ReadText(ToyExperimentFile());
  const std::string from = "plan_interval: 1.0}";
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos);
  text.replace(pos, from.size(), "plan_interval: 1.0, flight_delay_s: 0.05}");
  return text;
}

// SIGINT stops a run at the next evaluation boundary: exit code 130, summary "cancelled", the
// evaluations so far stored; --resume then completes it with the uninterrupted run's rows.
TEST(CliExitCodes, InterruptedRunIs130AndResumes) {
  const fs::path dir = Fresh("interrupt");
  std::ofstream(dir / "toy.yaml") << SlowToy();
  const std::string file = (dir / "toy.yaml").string();
  ASSERT_EQ(RunQuadtune("--log-level warn run --no-plot " + file + " --out " +
                            (dir / "full").string() + " --quiet",
                        dir / "full.log"),
            0);
  const int total = CountRows(dir / "full" / "results.sqlite");
  ASSERT_GT(total, 20);

  const fs::path cut = dir / "cut";
  const pid_t pid = test::Spawn({QuadtuneBinary(), "--log-level", "warn", "run", "--no-plot", file,
                                 "--out", cut.string(), "--quiet"},
                                (dir / "cut.log").string());
  int seen = 0;
  for (int i = 0; i < 6000 && seen < 8; ++i) {
    seen = CountRows(cut / "results.sqlite");
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  kill(pid, SIGINT);
  const int code = test::WaitExit(pid);
  ASSERT_EQ(code, 130) << ReadText(dir / "cut.log");
  EXPECT_EQ(ReadJson(cut / "summary.json")["status"], "cancelled");
  const int stored = CountRows(cut / "results.sqlite");
  EXPECT_GT(stored, 0);
  EXPECT_LT(stored, total);
  ASSERT_EQ(RunQuadtune("--log-level warn run --no-plot " + file + " --out " + cut.string() +
                            " --resume --quiet",
                        dir / "resume.log"),
            0)
      << ReadText(dir / "resume.log");
  EXPECT_EQ(ReadJson(cut / "summary.json")["status"], "completed");
  EXPECT_EQ(CountRows(cut / "results.sqlite"), total);
}

/// Every evaluation of a store without its wall-clock columns, one string per row.
std::vector<std::string> StoredRows(const fs::path& store) {
  std::vector<std::string> rows;
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(store.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db,
                           "SELECT method, kind, iteration, idx, params, value, status "
                           "FROM evaluation ORDER BY trial_id, kind, iteration, idx",
                           -1, &st, nullptr) == SQLITE_OK) {
      while (sqlite3_step(st) == SQLITE_ROW) {
        std::string row;
        for (int c = 0; c < 7; ++c) {
          const auto* text = sqlite3_column_text(st, c);
          row += std::string(text != nullptr ? reinterpret_cast<const char*>(text) : "") + "|";
        }
        rows.push_back(row);
      }
    }
    sqlite3_finalize(st);
  }
  sqlite3_close(db);
  return rows;
}

/// study.json's points without their wall-clock figures.
nlohmann::json PointsWithoutWallTime(const fs::path& study_json) {
  nlohmann::json points = ReadJson(study_json)["points"];
  for (auto& point : points) {
    for (auto& stage : point["stages"]) stage.erase("wall_s");
  }
  return points;
}

// study --resume: a finished study resumed replays its stored stages (the stores and the results
// stay as they are); a point whose store was lost is run again, to the same evaluations, while
// the other point's store is left alone.
TEST(CliStudy, ResumeReplaysStoredStagesAndRerunsALostOne) {
  const fs::path dir = Fresh("study_resume");
  std::ofstream(dir / "toy.yaml") << ReadText(ToyExperimentFile());
  std::ofstream(dir / "study.yaml")
      << "name: toy-study\nseed: 3\nexperiment: toy.yaml\n"
         "override: {repeats: 1, methods: [random, bo], budget: {flights: 4}}\n"
         "sweep: {key: planner.toy.gates, values: [4, 6], labels: [g4, g6]}\n"
         "validation: {flights: 0}\n";
  const std::string study = (dir / "study.yaml").string();
  const fs::path out = dir / "out";
  const std::string command =
      "--log-level warn study " + study + " --out " + out.string() + " --quiet --no-plot";
  ASSERT_EQ(RunQuadtune(command, dir / "study.log"), 0) << ReadText(dir / "study.log");
  const nlohmann::json points = PointsWithoutWallTime(out / "study.json");
  ASSERT_EQ(points.size(), 2u);
  const fs::path g4 = out / "g4" / "tuning" / "results.sqlite";
  const fs::path g6 = out / "g6" / "tuning" / "results.sqlite";
  const auto rows_g4 = StoredRows(g4);
  const auto rows_g6 = StoredRows(g6);
  ASSERT_FALSE(rows_g4.empty());
  ASSERT_FALSE(rows_g6.empty());
  EXPECT_NE(rows_g4, rows_g6);  // 4 and 6 gates: different problems

  ASSERT_EQ(RunQuadtune(command + " --resume", dir / "resume.log"), 0)
      << ReadText(dir / "resume.log");
  EXPECT_EQ(StoredRows(g4), rows_g4);
  EXPECT_EQ(StoredRows(g6), rows_g6);
  EXPECT_EQ(PointsWithoutWallTime(out / "study.json"), points);

  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(g6.string() + suffix);
  ASSERT_EQ(RunQuadtune(command + " --resume", dir / "resume2.log"), 0)
      << ReadText(dir / "resume2.log");
  EXPECT_EQ(StoredRows(g6), rows_g6);
  EXPECT_EQ(StoredRows(g4), rows_g4);
  EXPECT_EQ(PointsWithoutWallTime(out / "study.json"), points);
}

// A quadtune built without MPI, started as one of several MPI processes, refuses to run (each
// process would run the whole experiment into the same store). The launch is recognised from the
// launcher's environment (engine::MpiLaunchSize, unit-tested in engine_tests), so setting
// OMPI_COMM_WORLD_SIZE stands in for mpirun. An MPI build would start MPI instead: there the
// refusal cannot be reached and the test is skipped.
TEST(CliMpi, BuildWithoutMpiRefusesAMultiProcessLaunch) {
  if (QUADTUNE_TEST_HAVE_MPI) GTEST_SKIP() << "this quadtune is built with MPI";
  const fs::path dir = Fresh("no_mpi");
  const std::string cmd = "OMPI_COMM_WORLD_SIZE=2 " + QuadtuneBinary() + " run --no-plot " +
                          ToyExperimentFile() + " --out " + (dir / "out").string() + " > '" +
                          (dir / "log").string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 2) << ReadText(dir / "log");
  EXPECT_NE(ReadText(dir / "log").find("built without MPI"), std::string::npos)
      << ReadText(dir / "log");
  EXPECT_FALSE(fs::exists(dir / "out" / "results.sqlite"));
}

// Every failure kind is stored with a state that names it and its reason, and that state is
// what the tidy export, the Python loader and the report see: toy flights that collide (gates
// slower than braking from any speed of the range allows), toy flights whose planner raises
// (throw_speed_above below every speed of the range), real-planner flights cut by max_time,
// real-planner flights to a goal below the ground (no progress: stalled), and real-planner
// flights whose every plan is rejected (a_max 0.001: solver_failure). Random search varies the
// parameters, so the report's importance has pairs to rank: it must find none, as no flight
// succeeded. The tidy tables are typed the same way in the CSV and in quadtune.load: Optuna's
// leading columns (number, ..., datetime_start, datetime_complete, duration, state), then the
// store's own column list (stored_column) under its tidy names, params_* and terms_*; integral
// terms and integer parameters as integers, flags as booleans, timestamps as UTC datetimes,
// best_params as a mapping.
TEST(CliStoredStates, EachFailureIsNamedInTheTidyExportPythonAndReport) {
  const fs::path dir = Fresh("stored_states");
  struct Planted {
    std::string name, experiment, sets, state, message;
  };
  const std::string fast =
      " --set 'parameters=[{name: gain, lower: 0.05, upper: 1.5, default: 0.3}, {name: max_iter, "
      "lower: 2, upper: 40, type: integer, default: 20}, {name: speed, lower: 5.5, upper: 6.0, "
      "default: 5.8}, {name: margin, lower: 0.0, upper: 0.1, default: 0.05}]'";
  const std::string tiny = kExperiments + "tiny.yaml";
  const std::vector<Planted> planted = {
      {"collision", ToyExperimentFile(),
       "--set 'planner.toy={length: 20, gates: 6, gate_speed_min: 0.1, gate_speed_max: 0.2, "
       "plan_interval: 1.0}'" + fast,
       "collision", "completed"},
      {"error", ToyExperimentFile(), "--set planner.toy.throw_speed_above=1" + fast, "error",
       "exception: toy planner: speed "},
      {"timeout", tiny, "--set planner.max_time=2", "timeout",
       "timeout: mission not finished within max_time"},
      {"stalled", tiny,
       "--set 'planner.layout.mission.goal=[8.0, 0.0, -1.0]' --set planner.mission=go_to",
       "stalled", "stalled: no progress"},
      {"solver_failure", tiny, "--set 'planner.fixed={a_max: 0.001}'", "solver_failure", ""},
  };
  const std::string python_path =
      "PYTHONPATH='" + std::string(QUADTUNE_SOURCE_DIR) + "/experiments/python:" +
      std::string(QUADTUNE_SOURCE_DIR) + "/experiments/report' /usr/bin/python3 -c ";
  const std::map<std::string, std::string> tidy_names = {
      {"message", "state_reason"},
      {"wall_s", "duration"},
      {"started", "datetime_start"},
      {"finished", "datetime_complete"}};
  for (const Planted& p : planted) {
    SCOPED_TRACE(p.name);
    const fs::path out = dir / p.name;
    ASSERT_EQ(RunQuadtune("--log-level warn run --no-plot " + p.experiment + " --out " +
                              out.string() + " --quiet --set 'methods=[random]' --set repeats=1 "
                              "--set budget.flights=3 --set validation.maps=0 " + p.sets,
                          dir / "run.log"),
              0)
        << ReadText(dir / "run.log");
    ASSERT_EQ(RunQuadtune("--log-level warn export " + (out / "results.sqlite").string() +
                              " --tidy " + (out / "tidy").string(),
                          dir / "export.log"),
              0)
        << ReadText(dir / "export.log");
    // The tidy header: number, id, repeat, then the store's listed columns but the JSON objects
    // and status, under their tidy names.
    std::string listed = "number,id,repeat";
    for (const auto& row : test::Query(out / "results.sqlite",
                                       "SELECT name FROM stored_column WHERE tbl = 'evaluation' "
                                       "AND type != 'object' ORDER BY position")) {
      if (row[0] == "status") continue;
      listed += "," + (tidy_names.count(row[0]) ? tidy_names.at(row[0]) : row[0]);
    }
    EXPECT_EQ(FirstLine(out / "tidy" / "long_term.csv").rfind(listed + ",params_", 0), 0u)
        << FirstLine(out / "tidy" / "long_term.csv");
    const auto flights = ReadCsv(out / "tidy" / "long_term.csv");
    ASSERT_EQ(flights.size(), 3u);
    for (std::size_t i = 0; i < flights.size(); ++i) {
      const auto& f = flights[i];
      if (i > 0) EXPECT_LT(std::stoi(flights[i - 1].at("number")), std::stoi(f.at("number")));
      EXPECT_EQ(f.at("state"), p.state);
      EXPECT_EQ(f.at("state_reason").rfind(p.message, 0), 0u) << f.at("state_reason");
      // The experiment's integer parameter (tiny: n_pol; toy: max_iter) as a whole number.
      const std::string integer = p.experiment == tiny ? "params_n_pol" : "params_max_iter";
      EXPECT_EQ(f.at(integer).find_first_not_of("0123456789"), std::string::npos)
          << integer << " " << f.at(integer);
      if (p.name == "error") continue;  // no terms: the flight raised
      EXPECT_EQ(f.at("terms_completed"), p.state == "collision" ? "true" : "false");
      EXPECT_EQ(f.at("terms_n_c").find_first_not_of("0123456789"), std::string::npos)
          << f.at("terms_n_c");
      EXPECT_EQ(f.at("terms_plans").find_first_not_of("0123456789"), std::string::npos);
      EXPECT_EQ(f.at("datetime_start").size(), 27u) << f.at("datetime_start");
      EXPECT_EQ(f.at("datetime_start").substr(10, 1) + f.at("datetime_start").substr(26), "TZ");
      EXPECT_LE(f.at("datetime_start"), f.at("datetime_complete"));
    }
    // Python: the same columns, states and reasons, typed; and the report's importance over
    // successful flights only (here none).
    const fs::path py = dir / (p.name + ".py.log");
    const std::string script =
        "\"import quadtune, quadtune_report; r = quadtune.load('" + out.string() +
        "'); l = r.long; print(','.join(l.columns[:" +
        std::to_string(std::count(listed.begin(), listed.end(), ',') + 1) +
        "])); print(sorted(set(l['state']))); "
        "print(all(m.startswith('" + p.message + "') for m in l['state_reason'])); "
        "print(l['state'].dtype, l['number'].dtype, l['trial_id'].dtype, l['map_seed'].dtype, "
        "l['datetime_start'].dtype, l['duration'].dtype, "
        "l.get('terms_n_c', l['number']).dtype, "
        "l.get('terms_completed', l['state_reason'].isna().astype('boolean')).dtype, "
        "l.get('params_n_pol', l.get('params_max_iter')).dtype); "
        "print(sorted(n for t in r[:6] for n in t['number']) == list(range(sum(map(len, "
        "r[:6])))), "
        "all(b is None or isinstance(b, dict) for b in r.trials['best_params']), "
        "r.trials['finished'].dtype); "
        "print(len(quadtune_report.run_data('" + out.string() + "')['importance']))\"";
    ASSERT_EQ(std::system((python_path + script + " > '" + py.string() + "' 2>&1").c_str()), 0)
        << ReadText(py);
    EXPECT_EQ(ReadText(py), listed + "\n['" + p.state + "']\nTrue\n" +
                                "category Int64 Int64 UInt64 datetime64[ns, UTC] float64 Int64 "
                                "boolean Int64\nTrue True datetime64[ns, UTC]\n0\n");
  }
}

// export --help names every file each form writes: the three stored tables of --csv and the six
// tidy tables of --tidy.
TEST(CliExport, HelpNamesEveryFileItWrites) {
  const fs::path dir = Fresh("export_help");
  ASSERT_EQ(RunQuadtune("export --help", dir / "help.log"), 0) << ReadText(dir / "help.log");
  const std::string help = ReadText(dir / "help.log");
  for (const char* file : {"experiment.csv", "trials.csv", "evaluations.csv", "long_term.csv",
                           "short_term.csv", "validation.csv", "recheck.csv", "race.csv",
                           "incumbent.csv"}) {
    EXPECT_NE(help.find(file), std::string::npos) << file << " not in:\n" << help;
  }
}

// `quadtune paths` of the program in the build tree: the source tree's scripts, report libraries,
// package and assets; each environment override in its place (the installed program's paths:
// test/install/install_tool.sh).
TEST(CliPaths, BuildTreeProgramUsesTheSourceTreeAndTheOverrides) {
  const fs::path dir = Fresh("paths");
  const std::string src = QUADTUNE_SOURCE_DIR;
  ASSERT_EQ(RunQuadtune("paths", dir / "paths.log"), 0) << ReadText(dir / "paths.log");
  const std::string plain = ReadText(dir / "paths.log");
  const std::vector<std::string> source_tree = {
      "prefix: (none",
      "plot_script: " + src + "/experiments/plot/quadtune_plot.py\n",
      "report_script: " + src + "/experiments/report/quadtune_report.py\n",
      "report_js: " + src + "/experiments/report/js/node_modules\n",
      "python_package: " + src + "/experiments/python\n",
      "assets: " + src + "/assets\n"};
  for (const std::string& line : source_tree) {
    EXPECT_NE(plain.find(line), std::string::npos) << line << " not in:\n" << plain;
  }
  const std::string overrides =
      "env QUADTUNE_PLOT_SCRIPT=/p.py QUADTUNE_REPORT_SCRIPT=/r.py QUADTUNE_REPORT_JS=/js "
      "QUADTUNE_ASSETS=/a " + QuadtuneBinary() + " paths > '" + (dir / "env.log").string() + "'";
  ASSERT_EQ(std::system(overrides.c_str()), 0);
  const std::string env = ReadText(dir / "env.log");
  const std::vector<std::string> overridden = {"plot_script: /p.py\n", "report_script: /r.py\n",
                                               "report_js: /js\n",
                                               "assets: /a\nassets: " + src + "/assets\n"};
  for (const std::string& line : overridden) {
    EXPECT_NE(env.find(line), std::string::npos) << line << " not in:\n" << env;
  }
}

}  // namespace
}  // namespace quadtune
