// Scaled-down runs of every experiment the project ships (paper Sec. IV), end to end through the
// `quadtune` program with the real planner: the shipped files with small budgets (`--set`), then
// the figures and tables, checked for completeness and sanity.
//
//   benchmark comparison    experiments/benchmark.yaml          run + plot run
//   obstacle density        experiments/density_study.yaml      study (sweep + validation)
//   refinement              experiments/refinement_study.yaml   study (stages, moving bounds)
//   thread scaling          quadtune bench --csv --plot
//   one flight              quadtune fly (top-down figure)
// The changing-environment experiment has its own end-to-end test (test/adapt).
#include <gtest/gtest.h>
#include <unistd.h>
#include <sqlite3.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
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

const std::string kExperiments = std::string(QUADTUNE_SOURCE_DIR) + "/experiments/";

fs::path Fresh(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("quadtune_paper_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

/// A PNG file with content (a drawn figure is tens of kilobytes).
void ExpectFigure(const fs::path& png) {
  ASSERT_TRUE(fs::exists(png)) << png;
  EXPECT_GT(fs::file_size(png), 15000u) << png;
  std::ifstream in(png, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  EXPECT_EQ(std::string(magic + 1, 3), "PNG") << png;
}

double Number(const std::map<std::string, std::string>& row, const std::string& key) {
  const auto it = row.find(key);
  EXPECT_NE(it, row.end()) << key;
  return it == row.end() ? std::nan("") : std::stod(it->second);
}

/// Long-term values f_l of every trial of a store, in flight order, with the trial's method.
std::vector<std::pair<std::string, std::vector<double>>> LongValues(const fs::path& db) {
  std::vector<std::pair<std::string, std::vector<double>>> trials;
  std::map<std::string, std::size_t> index;
  for (const auto& t : Query(db, "SELECT id, method FROM trial ORDER BY id")) {
    index[t[0]] = trials.size();
    trials.push_back({t[1], {}});
  }
  for (const auto& e : Query(db,
                             "SELECT trial_id, value FROM evaluation WHERE kind = 'long' "
                             "ORDER BY trial_id, id")) {
    trials[index.at(e[0])].second.push_back(std::stod(e[1]));
  }
  return trials;
}

/// First flight (1-based) whose best f_l so far is within f* / 0.9 of the final best f*.
double FlightsTo90Percent(const std::vector<double>& values) {
  std::vector<double> best;
  double cur = std::numeric_limits<double>::infinity();
  for (double v : values) best.push_back(cur = std::min(cur, v));
  for (std::size_t k = 0; k < best.size(); ++k) {
    if (best[k] <= best.back() / 0.9) return static_cast<double>(k + 1);
  }
  return static_cast<double>(best.size());
}

double Mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? std::nan("") : sum / static_cast<double>(v.size());
}

// Paper Sec. IV-A: five methods, repeats on maps of identical density, best-so-far curves, f_l
// per flight, f_s counts and a summary table with Mann–Whitney U tests.
TEST(PaperExperiments, BenchmarkComparisonScaledDown) {
  const fs::path dir = Fresh("benchmark");
  const std::string out = (dir / "run").string();
  ASSERT_EQ(
      RunQuadtune("--log-level warn run --no-plot " + kExperiments + "benchmark.yaml --out " + out +
                      " --quiet --set repeats=2 --set budget.flights=3 "
                      "--set budget.default_flights=2 --set budget.short_evals_per_flight=4 "
                      "--set budget.queries_per_eval=2 --set pso.num_particles=4 "
                      "--set bo.initial_design_size=2 --set validation.maps=2 "
                      "--set recommend.flights=2",
                  dir / "run.log"),
      0)
      << ReadText(dir / "run.log");
  const fs::path db = fs::path(out) / "results.sqlite";
  // Every trial finished, with the budget's flights; bo_pso also scored θ_s by re-solves.
  const auto trials = Query(db, "SELECT method, repeat, status FROM trial ORDER BY id");
  ASSERT_EQ(trials.size(), 10u);
  std::map<std::string, int> per_method;
  for (const auto& t : trials) {
    EXPECT_EQ(t[2], "done") << t[0];
    ++per_method[t[0]];
  }
  for (const char* m : {"default", "random", "pso", "bo", "bo_pso"}) EXPECT_EQ(per_method[m], 2);
  for (const auto& row : Query(db,
                               "SELECT t.method, COUNT(*) FROM evaluation e JOIN trial t "
                               "ON e.trial_id = t.id WHERE e.kind = 'long' GROUP BY t.id")) {
    EXPECT_EQ(std::stoi(row[1]), row[0] == "default" ? 2 : 3) << row[0];
  }
  const auto shorts = Query(db, "SELECT COUNT(*) FROM evaluation WHERE kind = 'short'");
  ASSERT_EQ(shorts.size(), 1u);
  EXPECT_GE(std::stoi(shorts[0][0]), 2 * 3 * 4);  // bo_pso: 4 candidates per flight (and more)
  for (const auto& row : Query(db, "SELECT value, status FROM evaluation")) {
    EXPECT_TRUE(std::isfinite(std::stod(row[0])));
  }

  ASSERT_EQ(RunQuadtune("plot run " + out, dir / "plot.log"), 0) << ReadText(dir / "plot.log");
  ExpectFigure(fs::path(out) / "tuning.png");
  const auto table = ReadCsv(fs::path(out) / "tuning.csv");
  ASSERT_EQ(table.size(), 5u);
  std::set<std::string> methods;
  // The table's figures recomputed from the stored evaluations: a trial's final value is its best
  // f_l (the defaults: the mean of their flights); flights to 90% of the optimum per trial.
  std::map<std::string, std::vector<double>> finals, k90;
  for (const auto& [method, values] : LongValues(db)) {
    finals[method].push_back(method == "default" ? Mean(values)
                                                 : *std::min_element(values.begin(), values.end()));
    k90[method].push_back(FlightsTo90Percent(values));
  }
  for (const auto& r : table) {
    const std::string m = r.at("method");
    methods.insert(m);
    EXPECT_EQ(Number(r, "repeats"), 2.0);
    const double final_mean = Number(r, "final_mean");
    EXPECT_TRUE(std::isfinite(final_mean) && final_mean > 0.0) << m;
    EXPECT_NEAR(final_mean, Mean(finals[m]), 1e-9 * final_mean) << m;
    EXPECT_NEAR(Number(r, "final_min"), *std::min_element(finals[m].begin(), finals[m].end()),
                1e-9 * final_mean)
        << m;
    if (m != "default") EXPECT_DOUBLE_EQ(Number(r, "flights_to_90pct"), Mean(k90[m])) << m;
    // Mann–Whitney of each trial's flights to 90% against BO+PSO's: none for BO+PSO itself, the
    // defaults, or the same values.
    const double p90 = Number(r, "p_flights_to_90pct_vs_bo_pso");
    if (m == "default" || m == "bo_pso" || k90[m] == k90["bo_pso"]) {
      EXPECT_TRUE(std::isnan(p90)) << m;
    } else {
      EXPECT_GT(p90, 0.0) << m;
      EXPECT_LE(p90, 1.0) << m;
    }
  }
  EXPECT_EQ(methods, (std::set<std::string>{"default", "random", "pso", "bo", "bo_pso"}));
  const std::string md = ReadText(fs::path(out) / "tuning.md");
  for (const char* label : {"Default", "Random", "PSO only", "BO only", "BO+PSO", "p vs Default",
                            "Held-out validation"}) {
    EXPECT_NE(md.find(label), std::string::npos) << label;
  }
  // Held-out validation: the defaults once (trial id 0) and each tuned trial's recommended point
  // on the same 2 maps; one table row per method with its flights.
  const auto held_out = Query(db,
                              "SELECT trial_id, COUNT(*), COUNT(DISTINCT map_seed) FROM "
                              "evaluation WHERE kind = 'validation' GROUP BY trial_id");
  ASSERT_EQ(held_out.size(), 9u);  // defaults + 4 tuned methods × 2 repeats
  for (const auto& row : held_out) {
    EXPECT_EQ(row[1], "2") << "trial " << row[0];
    EXPECT_EQ(row[2], "2") << "trial " << row[0];
  }
  const auto validation = ReadCsv(fs::path(out) / "validation.csv");
  ASSERT_EQ(validation.size(), 5u);
  for (const auto& r : validation) {
    EXPECT_EQ(Number(r, "flights"), r.at("method") == "default" ? 2.0 : 4.0) << r.at("method");
    EXPECT_LE(Number(r, "collision_free"), Number(r, "completed")) << r.at("method");
  }
  ExpectFigure(fs::path(out) / "validation.png");
  // plot run --out: the same tables and figures in another folder; the run's own are kept.
  const fs::path elsewhere = dir / "figures";
  ASSERT_EQ(RunQuadtune("plot run " + out + " --out " + elsewhere.string(), dir / "plot2.log"), 0)
      << ReadText(dir / "plot2.log");
  ExpectFigure(elsewhere / "tuning.png");
  ExpectFigure(elsewhere / "validation.png");
  EXPECT_EQ(ReadText(elsewhere / "tuning.csv"), ReadText(fs::path(out) / "tuning.csv"));
  EXPECT_EQ(ReadText(elsewhere / "validation.csv"), ReadText(fs::path(out) / "validation.csv"));
}

// Paper Sec. IV-B2: tune at several densities, then validation flights of the tuned parameters
// (and the defaults) on new maps; flight time, emergency stops, evaluations to 90% of optimum.
TEST(PaperExperiments, DensityStudyScaledDown) {
  const fs::path dir = Fresh("density");
  const std::string out = (dir / "study").string();
  ASSERT_EQ(
      RunQuadtune(
          "--log-level warn study " + kExperiments + "density_study.yaml --out " + out +
              " --quiet --set override.repeats=1 --set override.budget.flights=3 "
              "--set override.budget.short_evals_per_flight=4 "
              "--set override.budget.queries_per_eval=2 "
              "--set override.bo.initial_design_size=2 "
              "--set override.pso.num_particles=4 --set validation.flights=2 "
              "--set override.recommend.flights=2 "
              "--set 'sweep.values=[layouts/forest_thin_3p0.yaml, layouts/forest_thin_0p9.yaml]' "
              "--set 'sweep.labels=[\"3.0\", \"0.9\"]'",
          dir / "study.log"),
      0)
      << ReadText(dir / "study.log");
  const auto rows = ReadCsv(fs::path(out) / "study.csv");
  ASSERT_EQ(rows.size(), 2u);
  // Validation: 2 flights × (1 tuned trial + the defaults) per density, all on new maps.
  const auto flights = ReadCsv(fs::path(out) / "validation.csv");
  EXPECT_EQ(flights.size(), 2u * 2u * 2u);
  const nlohmann::json study = nlohmann::json::parse(ReadText(fs::path(out) / "study.json"));
  ASSERT_EQ(study["points"].size(), 2u);
  for (std::size_t p = 0; p < rows.size(); ++p) {
    const auto& r = rows[p];
    EXPECT_EQ(r.at("method"), "bo_pso");
    EXPECT_EQ(Number(r, "validation_flights"), 2.0);
    EXPECT_GT(Number(r, "flight_time_mean"), 5.0);
    EXPECT_GT(Number(r, "default_flight_time_mean"), 5.0);
    // The table's figures recomputed from validation.csv and the point's store.
    std::vector<double> tuned_time, default_time;
    double max_stops = 0.0;
    for (const auto& f : flights) {
      if (Number(f, "point") != static_cast<double>(p)) continue;
      if (f.at("method") == "default") {
        default_time.push_back(Number(f, "flight_time"));
      } else if (f.at("method") == "bo_pso") {
        tuned_time.push_back(Number(f, "flight_time"));
        max_stops = std::max(max_stops, Number(f, "emergency_stops"));
      }
    }
    ASSERT_EQ(tuned_time.size(), 2u) << p;
    ASSERT_EQ(default_time.size(), 2u) << p;
    EXPECT_NEAR(Number(r, "flight_time_mean"), Mean(tuned_time), 1e-9 * Mean(tuned_time)) << p;
    EXPECT_NEAR(Number(r, "default_flight_time_mean"), Mean(default_time),
                1e-9 * Mean(default_time))
        << p;
    EXPECT_EQ(Number(r, "max_emergency_stops"), max_stops) << p;
    const auto& last = study["points"][p]["stages"].back();
    const fs::path store = fs::path(out) / std::string(last["store"]);
    std::vector<double> k90;
    for (const auto& [method, values] : LongValues(store)) {
      if (method == "bo_pso") k90.push_back(FlightsTo90Percent(values));
    }
    ASSERT_EQ(k90.size(), 1u) << p;
    EXPECT_DOUBLE_EQ(Number(r, "flights_to_90pct_mean"), k90[0]) << p;
    // Re-solves before that flight: at most all the trial's θ_s candidates × queries_per_eval.
    EXPECT_LE(
        Number(r, "resolves_to_90pct_mean"),
        std::stod(Query(store, "SELECT COUNT(*) FROM evaluation WHERE kind = 'short'")[0][0]) *
                2.0 +
            1e-9);
  }
  ExpectFigure(fs::path(out) / "study_sweep.png");
  EXPECT_NE(ReadText(fs::path(out) / "study.md").find("90% optimum"), std::string::npos);
  for (const char* label : {"3.0", "0.9"}) {
    EXPECT_TRUE(fs::exists(fs::path(out) / label / "tuning" / "results.sqlite")) << label;
  }
  // `plot study --out` redraws into another folder: the same tables, the study left as it was.
  const fs::path replot = dir / "replot";
  const std::string md_before = ReadText(fs::path(out) / "study.md");
  ASSERT_EQ(RunQuadtune("plot study " + out + " --out " + replot.string(), dir / "replot.log"), 0)
      << ReadText(dir / "replot.log");
  for (const char* file : {"study.md", "study.csv", "study_validation.csv"}) {
    EXPECT_EQ(ReadText(replot / file), ReadText(fs::path(out) / file)) << file;
  }
  ExpectFigure(replot / "study_sweep.png");
  EXPECT_EQ(ReadText(fs::path(out) / "study.md"), md_before);
}

// Paper Sec. III-E/IV-C: tune in a low-fidelity world, refine in a high-fidelity one inside
// damped moving bounds around the low-fidelity optimum; both drones.
TEST(PaperExperiments, RefinementStudyScaledDown) {
  const fs::path dir = Fresh("refinement");
  const std::string out = (dir / "study").string();
  ASSERT_EQ(
      RunQuadtune("--log-level warn study " + kExperiments + "refinement_study.yaml --out " + out +
                      " --quiet --set override.budget.flights=3 "
                      "--set override.bo.initial_design_size=2 "
                      "--set stages.1.override.budget.flights=3 "
                      "--set stages.1.override.bo.initial_design_size=1 "
                      "--set validation.flights=1 --set override.recommend.flights=2",
                  dir / "study.log"),
      0)
      << ReadText(dir / "study.log");
  const nlohmann::json study = nlohmann::json::parse(ReadText(fs::path(out) / "study.json"));
  ASSERT_EQ(study["points"].size(), 2u);  // research_1kg and agile_small
  for (const auto& point : study["points"]) {
    const std::string label = point["label"];
    ASSERT_EQ(point["stages"].size(), 2u) << label;
    const auto& low = point["stages"][0];
    const auto& high = point["stages"][1];
    EXPECT_EQ(high["start_from"], "low_fidelity");
    EXPECT_EQ(high["start"], low["best"]) << label;
    // The high-fidelity search starts inside start ± half_width (unit-cube widths, 0.1) of
    // every parameter: its first flight's parameters lie there.
    const fs::path db = fs::path(out) / std::string(high["store"]);
    const auto first = Query(db,
                             "SELECT params FROM evaluation WHERE kind = 'long' ORDER BY "
                             "iteration, idx LIMIT 1");
    ASSERT_EQ(first.size(), 1u) << label;
    const nlohmann::json params = nlohmann::json::parse(first[0][0]);
    for (const auto& p : high["space"]) {
      const std::string name = p["name"];
      const double lo = p["lower"], hi = p["upper"];
      const bool log = p["log"];
      auto unit = [&](double v) {
        return log ? (std::log(v) - std::log(lo)) / (std::log(hi) - std::log(lo))
                   : (v - lo) / (hi - lo);
      };
      const double u_start = unit(high["start"][name].get<double>());
      const double u_first = unit(params[name].get<double>());
      const double slack = name == "n_pol" ? 0.5 / (hi - lo) : 1e-9;  // integer rounding
      EXPECT_LE(std::abs(u_first - u_start), 0.1 + slack) << label << " " << name;
    }
    ExpectFigure(fs::path(out) / ("refinement_" + label + ".png"));
  }
  // Validation in the high-fidelity world: defaults, low-fidelity best, refined best per drone.
  const auto flights = ReadCsv(fs::path(out) / "validation.csv");
  EXPECT_EQ(flights.size(), 2u * 3u);
  for (const auto& f : flights) EXPECT_GT(Number(f, "flight_time"), 0.0);
}

// Thread scaling: flights/s and re-solves/s per thread count, with the figure.
TEST(PaperExperiments, ThreadScalingWritesCsvAndFigure) {
  const fs::path dir = Fresh("scaling");
  const fs::path csv = dir / "bench.csv";
  ASSERT_EQ(RunQuadtune("--log-level warn bench " + kExperiments +
                            "tiny.yaml --max-threads 2 "
                            "--flights 2 --resolves 40 --csv " +
                            csv.string() + " --plot",
                        dir / "bench.log"),
            0)
      << ReadText(dir / "bench.log");
  const auto rows = ReadCsv(csv);
  ASSERT_EQ(rows.size(), 2u);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    EXPECT_EQ(Number(rows[i], "threads"), static_cast<double>(i + 1));
    EXPECT_EQ(Number(rows[i], "flights"), 2.0);
    EXPECT_EQ(Number(rows[i], "resolves"), 40.0);
    EXPECT_EQ(rows[i].at("experiment"), "tiny");
    EXPECT_GE(Number(rows[i], "cores"), 1.0);
    EXPECT_GT(Number(rows[i], "flights_per_s"), 0.0);
    EXPECT_GT(Number(rows[i], "resolves_per_s"), 0.0);
    // The speed-up is the one-thread mixed time over this row's (6 significant digits in CSV).
    const double speedup = Number(rows[0], "mixed_s") / Number(rows[i], "mixed_s");
    EXPECT_NEAR(Number(rows[i], "mixed_speedup"), speedup, 1e-4 * speedup);
  }
  ExpectFigure(dir / "bench.png");
}

// `--spacing` uses the experiments' own forest files: `layout --spacing 1.3 --seed 1` writes what
// `layout --layout-options assets/layouts/forest_1p3.yaml --seed 1` writes, and the thin forest's
// options regenerate the shipped saved layout (made from forest_thin_1p3.yaml, seed 1) byte for
// byte.
TEST(PaperExperiments, SpacingOptionUsesTheShippedForest) {
  const fs::path dir = Fresh("spacing_forest");
  const std::string assets = std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/";
  for (const auto& [args, file] :
       {std::pair<std::string, std::string>{"--spacing 1.3", "spacing.yaml"},
        {"--layout-options " + assets + "forest_1p3.yaml", "options.yaml"},
        {"--layout-options " + assets + "forest_thin_1p3.yaml", "thin.yaml"}}) {
    ASSERT_EQ(
        RunQuadtune("--log-level warn layout " + args + " --seed 1 --out " + (dir / file).string(),
                    dir / "layout.log"),
        0)
        << ReadText(dir / "layout.log");
  }
  EXPECT_EQ(ReadText(dir / "spacing.yaml"), ReadText(dir / "options.yaml"));
  EXPECT_NE(ReadText(dir / "spacing.yaml").find("density: free_gap"), std::string::npos);
  std::string shipped = ReadText(fs::path(assets) / "forest_1p3_seed1.layout.yaml");
  shipped = shipped.substr(shipped.find("format:"));  // past the comment header
  EXPECT_EQ(ReadText(dir / "thin.yaml"), shipped);
}

// Any flight: a top-down figure of the layout with the flown and the planned trajectories.
TEST(PaperExperiments, FlightWritesTopDownFigure) {
  const fs::path dir = Fresh("flight");
  ASSERT_EQ(RunQuadtune("--log-level warn fly --spacing 3.0 --seed 2 --out " + (dir / "f").string(),
                        dir / "fly.log"),
            0)
      << ReadText(dir / "fly.log");
  ExpectFigure(dir / "f" / "flight_topdown.png");
  ASSERT_EQ(
      RunQuadtune("plot flight " + (dir / "f").string() + " --out " + (dir / "again.png").string(),
                  dir / "plot.log"),
      0)
      << ReadText(dir / "plot.log");
  ExpectFigure(dir / "again.png");
  const nlohmann::json summary = nlohmann::json::parse(ReadText(dir / "f" / "summary.json"));
  EXPECT_EQ(summary["status"], "completed");
  EXPECT_GT(ReadCsv(dir / "f" / "plans.csv").size(), 50u);
  // The flight log ends where the summary says: its time is the flight time.
  const auto flight = ReadCsv(dir / "f" / "flight.csv");
  ASSERT_FALSE(flight.empty());
  EXPECT_NEAR(Number(flight.back(), "t"), summary["flight_time"].get<double>(), 0.1);  // 20 Hz log
}

}  // namespace
}  // namespace quadtune
