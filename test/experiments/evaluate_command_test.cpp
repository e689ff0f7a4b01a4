// `quadtune evaluate` and the peer tuners built on it (scripts/peers/): a point flown on the
// held-out maps gives the rows `quadtune run`'s validation stored for it, a tuning map is the
// map the run's flight k flew, bad --param values are refused, and Optuna TPE and irace tune the
// toy planner through it.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "../cli_util.hpp"
#include "../sqlite_util.hpp"

namespace quadtune {
namespace {

namespace fs = std::filesystem;
using test::Query;
using test::ReadCsv;
using test::ReadText;
using test::RunQuadtune;
using test::ToyExperimentFile;

fs::path Fresh(const std::string& name) { return test::FreshTempDir("quadtune_evaluate_" + name); }

TEST(Evaluate, HeldOutRowsEqualTheRunsValidationOfTheDefaults) {
  const fs::path dir = Fresh("heldout");
  const std::string run = (dir / "run").string();
  ASSERT_EQ(RunQuadtune("--log-level warn run --no-plot --quiet " + ToyExperimentFile() +
                            " --out " + run + " --set 'methods=[default]' --set repeats=1",
                        dir / "run.log"),
            0)
      << ReadText(dir / "run.log");
  ASSERT_EQ(RunQuadtune("--log-level warn evaluate " + ToyExperimentFile() +
                            " --maps heldout --count 3 --csv " + (dir / "e.csv").string(),
                        dir / "e.log"),
            0)
      << ReadText(dir / "e.log");
  const auto rows = ReadCsv(dir / "e.csv");
  const auto stored = Query(fs::path(run) / "results.sqlite",
                            "SELECT iteration, map_seed, flight_seed, value FROM evaluation WHERE "
                            "kind = 'validation' AND trial_id = 0 ORDER BY iteration");
  ASSERT_EQ(rows.size(), 3u);
  ASSERT_EQ(stored.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(rows[i].at("index"), stored[i][0]);
    EXPECT_EQ(rows[i].at("map_seed"), stored[i][1]);
    EXPECT_EQ(rows[i].at("flight_seed"), stored[i][2]);
    EXPECT_DOUBLE_EQ(std::stod(rows[i].at("value")), std::stod(stored[i][3]));
  }
}

TEST(Evaluate, TuningMapKIsTheMapOfTheRunsFlightK) {
  const fs::path dir = Fresh("tuning");
  const std::string run = (dir / "run").string();
  ASSERT_EQ(RunQuadtune("--log-level warn run --no-plot --quiet " + ToyExperimentFile() +
                            " --out " + run + " --set 'methods=[random]' --set repeats=2",
                        dir / "run.log"),
            0)
      << ReadText(dir / "run.log");
  ASSERT_EQ(RunQuadtune("--log-level warn evaluate " + ToyExperimentFile() +
                            " --maps tuning --repeat 1 --first 2 --count 4 --param speed=2.5 "
                            "--csv " + (dir / "e.csv").string(),
                        dir / "e.log"),
            0)
      << ReadText(dir / "e.log");
  const auto rows = ReadCsv(dir / "e.csv");
  // The run's flights of repeat 1 in the order flown (rounds, then index in the round).
  const auto flown = Query(fs::path(run) / "results.sqlite",
                           "SELECT e.map_seed FROM evaluation e JOIN trial t ON t.id = e.trial_id "
                           "WHERE e.kind = 'long' AND t.repeat = 1 ORDER BY e.iteration, e.idx");
  ASSERT_EQ(rows.size(), 4u);
  ASSERT_GE(flown.size(), 6u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(rows[i].at("map_seed"), flown[2 + i][0]) << i;
    EXPECT_EQ(rows[i].at("maps"), "tuning");
    EXPECT_TRUE(std::isfinite(std::stod(rows[i].at("value"))));
  }
}

TEST(Evaluate, RefusesParametersOutsideThePlannerOrTheBox) {
  const fs::path dir = Fresh("refuse");
  struct Case {
    std::string args, words;
  };
  for (const Case& c : {Case{"--param speed=9", "[0.5, 6]"},
                        Case{"--param max_iter=2.5", "an integer"},
                        Case{"--param nope=1", "allowed: "},
                        Case{"--param speed", "NAME=VALUE"},
                        Case{"--param speed=fast", "not a finite number"},
                        Case{"--maps race --repeat 7", "--repeat"}}) {
    EXPECT_EQ(RunQuadtune("evaluate " + ToyExperimentFile() + " " + c.args, dir / "log"), 2)
        << c.args;
    const std::string log = ReadText(dir / "log");
    EXPECT_NE(log.find(c.words), std::string::npos) << c.args << ": " << log;
  }
}

/// Runs a peer script on the toy experiment with quadtune_test_cli; returns its JSON output.
nlohmann::json RunPeer(const std::string& command, const fs::path& dir) {
  const std::string cmd = "cd '" + std::string(QUADTUNE_SOURCE_DIR) + "' && QUADTUNE='" +
                          test::QuadtuneBinary() + "' " + command + " > '" +
                          (dir / "peer.log").string() + "' 2>&1";
  EXPECT_EQ(std::system(cmd.c_str()), 0) << ReadText(dir / "peer.log");
  return nlohmann::json::parse(ReadText(dir / "out.json"), nullptr, false);
}

void ExpectInsideToyBox(const nlohmann::json& point) {
  ASSERT_TRUE(point.is_object()) << point.dump();
  const std::map<std::string, std::pair<double, double>> box = {
      {"gain", {0.05, 1.5}}, {"max_iter", {2, 40}}, {"speed", {0.5, 6.0}}, {"margin", {0, 3}}};
  for (const auto& [name, range] : box) {
    ASSERT_TRUE(point.contains(name)) << name;
    const double v = point[name].get<double>();
    EXPECT_GE(v, range.first) << name;
    EXPECT_LE(v, range.second) << name;
  }
}

TEST(Peers, OptunaTpeTunesThroughEvaluate) {
  const fs::path dir = Fresh("optuna");
  const auto j = RunPeer("/usr/bin/python3 scripts/peers/optuna_tpe.py " + ToyExperimentFile() +
                             " --budget 6 --out " + (dir / "out.json").string(),
                         dir);
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j["flights"], 6);
  ExpectInsideToyBox(j["params"]);
}

TEST(Peers, IraceTunesThroughEvaluate) {
  const fs::path dir = Fresh("irace");
  std::ofstream(dir / "box.tsv") << "name\tlower\tupper\tlog\tinteger\ngain\t0.05\t1.5\t0\t0\n"
                                    "max_iter\t2\t40\t0\t1\nspeed\t0.5\t6.0\t0\t0\n"
                                    "margin\t0.0\t3.0\t0\t0\n";
  const std::string irace = "Rscript scripts/peers/irace_tune.R " + ToyExperimentFile() +
                            " 0 80 3 " + (dir / "out.json").string() + " " +
                            (dir / "box.tsv").string();
  const auto j = RunPeer(irace + " planner.toy.gates=8", dir);
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j["tuner"], "irace");
  ExpectInsideToyBox(j["params"]);
  // The KEY=VALUE after the box reach every flight: an out-of-range one stops the tuning with
  // quadtune's error naming the key.
  const std::string bad = "cd '" + std::string(QUADTUNE_SOURCE_DIR) + "' && QUADTUNE='" +
                          test::QuadtuneBinary() + "' " + irace + " planner.toy.gates=-1 > '" +
                          (dir / "bad.log").string() + "' 2>&1";
  EXPECT_NE(std::system(bad.c_str()), 0);
  EXPECT_NE(ReadText(dir / "bad.log").find("planner.toy.gates"), std::string::npos)
      << ReadText(dir / "bad.log");
}

// scripts/peers/density_oracle.py on a toy study swept over two values: its grid (named on the
// command line) flies the study's held-out maps with their seeds, so the grid point at the
// defaults reproduces the study's own held-out flights of the defaults, and the oracle is the
// grid's best point. With `--peers 8`, irace and Optuna tune that point with a study trial's
// budget and fly the same held-out maps; the other point has no peer rows.
TEST(Peers, DensityOracleFliesItsGridOnTheStudysHeldOutMaps) {
  const fs::path dir = Fresh("density_oracle");
  std::ofstream(dir / "study.yaml")
      << "name: toy_density\nseed: 5\nexperiment: " << ToyExperimentFile() << "\n"
      << "override: {name: toy_density, methods: [bo], repeats: 1, budget: {flights: 30}}\n"
      << "sweep: {key: planner.toy.gates, values: [4, 8], labels: [\"4\", \"8\"]}\n"
      << "validation: {flights: 3}\n";
  const fs::path study = dir / "study";
  ASSERT_EQ(RunQuadtune("--log-level warn study --no-plot --quiet " + (dir / "study.yaml").string() +
                            " --out " + study.string(),
                        dir / "study.log"),
            0)
      << ReadText(dir / "study.log");
  const fs::path out = dir / "out";
  const std::string cmd = "cd '" + std::string(QUADTUNE_SOURCE_DIR) + "' && QUADTUNE='" +
                          test::QuadtuneBinary() +
                          "' /usr/bin/python3 scripts/peers/density_oracle.py '" +
                          (dir / "study.yaml").string() + "' --study '" + study.string() +
                          "' --planner toy --grid speed=2,2.5 --grid margin=0.2,0.5 --peers 8 "
                          "--repeats 1 --out '" +
                          out.string() + "' --work '" + (dir / "work").string() + "' > '" +
                          (dir / "oracle.log").string() + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << ReadText(dir / "oracle.log");
  const auto validation = ReadCsv(study / "validation.csv");
  const auto heldout = ReadCsv(out / "heldout.csv");
  for (const std::string label : {"4", "8"}) {
    const auto grid = ReadCsv(out / ("oracle_grid_toy_free_gap_" + label + ".csv"));
    ASSERT_EQ(grid.size(), 4u) << label;
    double best = 1e300, at_defaults = -1.0;
    for (const auto& g : grid) {
      const double mean = std::stod(g.at("mean_f_l"));
      best = std::min(best, mean);
      if (std::stod(g.at("speed")) == 2.0 && std::stod(g.at("margin")) == 0.5) at_defaults = mean;
    }
    // The study's held-out flights of the defaults, and its held-out map seeds.
    std::vector<double> defaults;
    std::multiset<std::string> seeds;
    for (const auto& v : validation) {
      if (v.at("label") != label || v.at("method") != "default") continue;
      defaults.push_back(std::stod(v.at("f_l")));
      seeds.insert(v.at("map_seed"));
    }
    ASSERT_EQ(defaults.size(), 3u) << label;
    double mean_defaults = 0.0;
    for (double d : defaults) mean_defaults += d / 3.0;
    EXPECT_NEAR(at_defaults, mean_defaults, 1e-4) << label;  // validation.csv holds 4 decimals
    std::vector<double> oracle;
    std::multiset<std::string> oracle_seeds;
    for (const auto& h : heldout) {
      if (h.at("tuner") != "oracle" || std::stod(h.at("spacing")) != std::stod(label)) continue;
      oracle.push_back(std::stod(h.at("f_l")));
      oracle_seeds.insert(h.at("map_seed"));
    }
    ASSERT_EQ(oracle.size(), 3u) << label;
    EXPECT_EQ(oracle_seeds, seeds) << label;
    EXPECT_NEAR((oracle[0] + oracle[1] + oracle[2]) / 3.0, best, 1e-6) << label;
    EXPECT_LE(best, mean_defaults + 1e-9) << label;
    for (const std::string peer : {"irace", "optuna_tpe"}) {
      std::multiset<std::string> peer_seeds;
      for (const auto& h : heldout) {
        if (h.at("tuner") == peer && std::stod(h.at("spacing")) == std::stod(label)) {
          peer_seeds.insert(h.at("map_seed"));
        }
      }
      EXPECT_EQ(peer_seeds, label == "8" ? seeds : std::multiset<std::string>{}) << label << peer;
    }
  }
}

}  // namespace
}  // namespace quadtune
