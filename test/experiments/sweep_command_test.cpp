// `quadtune sweep` end to end: the toy experiment at two settings (layouts), its CSV files, tables
// and figure checked for content; the same seed at 1 and 2 threads; the refusal to overwrite; and
// a scaled-down sweep of the real planner (experiments/tiny.yaml).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "../cli_util.hpp"

namespace quadtune {
namespace {

namespace fs = std::filesystem;
using test::ReadCsv;
using test::ReadText;
using test::RunQuadtune;
using test::ToyExperimentFile;

const std::string kExperiments = std::string(QUADTUNE_SOURCE_DIR) + "/experiments/";

fs::path Fresh(const std::string& name) { return test::FreshTempDir("quadtune_sweep_" + name); }

/// A cell of a CSV row as a number (NaN, and a test failure, when the column is missing).
double Number(const std::map<std::string, std::string>& row, const std::string& key) {
  const auto it = row.find(key);
  if (it == row.end()) {
    ADD_FAILURE() << "no column " << key;
    return std::nan("");
  }
  return std::stod(it->second);
}

/// The indices of f_l and f_s: in [−0.2, 1.2] with finite intervals; f_s's θ_l indices are 0.
void ExpectPlausibleIndices(const std::vector<std::map<std::string, std::string>>& rows,
                            std::size_t layouts, std::size_t parameters) {
  ASSERT_EQ(rows.size(), layouts * 5 * parameters);  // outputs f_l, t_f, n_c, n_e, f_s
  int checked = 0;
  for (const auto& r : rows) {
    const std::string& out = r.at("output");
    if (out != "f_l" && out != "f_s") continue;
    ++checked;
    for (const char* k : {"S1", "ST"}) {
      const double v = Number(r, k);
      EXPECT_TRUE(v >= -0.2 && v <= 1.2) << out << " " << r.at("parameter") << " " << k << " " << v;
      const double lo = Number(r, std::string(k) + "_lo");
      const double hi = Number(r, std::string(k) + "_hi");
      EXPECT_TRUE(std::isfinite(lo) && std::isfinite(hi) && lo <= hi) << out << " " << k;
    }
    if (out == "f_s" && r.at("kind") == "long") {
      EXPECT_EQ(Number(r, "S1"), 0.0) << r.at("parameter");
      EXPECT_EQ(Number(r, "ST"), 0.0) << r.at("parameter");
    }
    EXPECT_GT(Number(r, "variance"), 0.0) << out;
  }
  EXPECT_EQ(checked, static_cast<int>(layouts * 2 * parameters));
}

// The toy planner (4 parameters) at two gate counts: N·(d+2)·K rows per setting (N = 256: the
// toy's f_l is rough, so smaller designs give estimates outside [−0.2, 1.2]).
TEST(SweepCommand, ToySweepAtTwoSettingsWritesCheckedOutputs) {
  const fs::path dir = Fresh("toy");
  const std::string out = (dir / "out").string();
  ASSERT_EQ(RunQuadtune("sweep " + ToyExperimentFile() + " --out " + out +
                            " --points 256 --maps 2 --queries 5 --seed 9 --threads 2 "
                            "--bootstrap 200 --layout-key planner.toy.gates --layouts 4 8",
                        dir / "sweep.log"),
            0)
      << ReadText(dir / "sweep.log");
  const std::string log = ReadText(dir / "sweep.log");
  EXPECT_NE(log.find("ETA"), std::string::npos) << log;
  const std::size_t d = 4, n = 256, k = 2;
  const auto flights = ReadCsv(fs::path(out) / "sweep.csv");
  ASSERT_EQ(flights.size(), 2 * n * (d + 2) * k);
  std::map<std::string, int> per_layout;
  std::set<std::string> map_seeds;
  std::map<std::string, std::set<std::string>> flight_seeds;
  for (const auto& f : flights) {
    ++per_layout[f.at("layout")];
    map_seeds.insert(f.at("map_seed"));
    flight_seeds[f.at("layout")].insert(f.at("flight_seed"));
    EXPECT_EQ(f.at("status"), "ok") << f.at("message");
    for (const char* col : {"gain", "max_iter", "speed", "margin", "f_l", "t_f", "n_c", "n_e"}) {
      EXPECT_TRUE(std::isfinite(Number(f, col))) << col;
    }
    EXPECT_GE(Number(f, "speed"), 0.5);
    EXPECT_LE(Number(f, "speed"), 6.0);
  }
  EXPECT_EQ(per_layout, (std::map<std::string, int>{{"4", 3072}, {"8", 3072}}));
  EXPECT_EQ(map_seeds.size(), k);  // every point flies on the same maps
  EXPECT_EQ(flight_seeds["4"].size(), n * (d + 2) * k);
  const auto points = ReadCsv(fs::path(out) / "points.csv");
  ASSERT_EQ(points.size(), 2 * n * (d + 2));
  for (const auto& p : points) {
    EXPECT_TRUE(std::isfinite(Number(p, "f_s")) && Number(p, "f_s") > 0.0);
    EXPECT_TRUE(std::isfinite(Number(p, "f_l")) && Number(p, "f_l") > 0.0);
  }
  ExpectPlausibleIndices(ReadCsv(fs::path(out) / "indices.csv"), 2, d);
  // The toy f_l is dominated by the speed: its total effect is the largest of the four.
  for (const auto& r : ReadCsv(fs::path(out) / "indices.csv")) {
    if (r.at("output") == "f_l" && r.at("parameter") == "speed") {
      EXPECT_GT(Number(r, "ST"), 0.3);
    }
  }
  const std::string md = ReadText(fs::path(out) / "indices.md");
  for (const char* text : {"## 4", "## 8", "Spearman", "| f_l |", "| f_s |", "speed"}) {
    EXPECT_NE(md.find(text), std::string::npos) << text;
  }
  const auto summary = nlohmann::json::parse(ReadText(fs::path(out) / "summary.json"));
  ASSERT_EQ(summary["layouts"].size(), 2u);
  EXPECT_EQ(summary["layouts"][0]["flights"], n * (d + 2) * k);
  EXPECT_EQ(summary["layouts"][0]["queries_used"], 5);
  EXPECT_TRUE(summary["layouts"][0]["spearman_fs_fl"].is_number());
  // A drawn figure of five panels is tens of kilobytes.
  EXPECT_GT(test::PngBytes(fs::path(out) / "sweep.png"), 15000u);

  // A non-empty --out is refused without --overwrite, and the message says so.
  EXPECT_EQ(RunQuadtune("sweep " + ToyExperimentFile() + " --out " + out + " --points 2",
                        dir / "again.log"),
            2);
  EXPECT_NE(ReadText(dir / "again.log").find("--overwrite"), std::string::npos)
      << ReadText(dir / "again.log");
}

// Same seed at 1 and 2 threads: byte-identical sweep.csv, points.csv and indices.csv.
TEST(SweepCommand, SameSeedSameFilesAtOneAndTwoThreads) {
  const fs::path dir = Fresh("threads");
  for (int threads : {1, 2}) {
    const std::string out = (dir / ("t" + std::to_string(threads))).string();
    ASSERT_EQ(RunQuadtune("--log-level warn sweep " + ToyExperimentFile() + " --out " + out +
                              " --points 8 --maps 2 --queries 4 --bootstrap 50 --no-plot "
                              "--threads " +
                              std::to_string(threads),
                          dir / "sweep.log"),
              0)
        << ReadText(dir / "sweep.log");
    EXPECT_FALSE(fs::exists(fs::path(out) / "sweep.png"));
  }
  for (const char* file : {"sweep.csv", "points.csv", "indices.csv"}) {
    const std::string one = ReadText(dir / "t1" / file);
    EXPECT_GT(one.size(), 100u) << file;
    EXPECT_EQ(one, ReadText(dir / "t2" / file)) << file;
  }
}

// The real planner: a scaled-down sweep of experiments/tiny.yaml (6 parameters, Ipopt, Bullet).
TEST(SweepCommand, TinyIpoptSweepRuns) {
  const fs::path dir = Fresh("tiny");
  const std::string out = (dir / "out").string();
  ASSERT_EQ(RunQuadtune("--log-level warn sweep " + kExperiments + "tiny.yaml --out " + out +
                            " --points 2 --maps 1 --queries 4 --bootstrap 50 --threads 2 --no-plot",
                        dir / "sweep.log"),
            0)
      << ReadText(dir / "sweep.log");
  const auto flights = ReadCsv(fs::path(out) / "sweep.csv");
  ASSERT_EQ(flights.size(), 2u * 8u);
  int completed = 0;
  for (const auto& f : flights) {
    EXPECT_TRUE(std::isfinite(Number(f, "f_l")));
    completed += Number(f, "completed") == 1.0 ? 1 : 0;
  }
  EXPECT_GT(completed, 0);
  const auto summary = nlohmann::json::parse(ReadText(fs::path(out) / "summary.json"));
  EXPECT_GT(summary["layouts"][0]["queries_recorded"].get<int>(), 4);
  EXPECT_EQ(summary["layouts"][0]["queries_used"], 4);
  const auto indices = ReadCsv(fs::path(out) / "indices.csv");
  EXPECT_EQ(indices.size(), 5u * 6u);
  for (const auto& r : indices) {
    if (r.at("output") == "f_s" && r.at("kind") == "long") {
      EXPECT_EQ(Number(r, "ST"), 0.0);
    }
  }
}

}  // namespace
}  // namespace quadtune
