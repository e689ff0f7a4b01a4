// A stored flight flown again, the tidy export and the Python reader, on one tiny tuning run
// (experiments/tiny.yaml) through the `quadtune` program:
//
//   quadtune fly --from STORE --evaluation ID --out DIR   same t_f, n_c, n_e as the stored row
//   quadtune export STORE --tidy DIR                      one row per evaluation, exact values
//   experiments/python/quadtune load()                    the same rows as pandas DataFrames
//   quadtune report DIR                                   a page holding the run's data
// and a stored flight of the EGO planner (experiments/tiny_ego.yaml) flown again the same, and a
// flight's parameters (`fly --set`) in its summary.json.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdio>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
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

/// Output of a shell command (stdout).
std::string Capture(const std::string& command) {
  std::string out;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return out;
  char buffer[512];
  while (fgets(buffer, sizeof buffer, pipe) != nullptr) out += buffer;
  pclose(pipe);
  return out;
}

/// `quadtune run --no-plot` of experiments/`yaml` into a fresh folder `name`; its store.
fs::path RunInto(const std::string& name, const std::string& yaml, fs::path* dir) {
  *dir = test::FreshTempDir(name);
  const fs::path run = *dir / "run";
  EXPECT_EQ(RunQuadtune("--log-level warn run --no-plot " + std::string(QUADTUNE_SOURCE_DIR) +
                            "/experiments/" + yaml + " --out " + run.string(),
                        *dir / "run.log"),
            0)
      << ReadText(*dir / "run.log");
  return run / "results.sqlite";
}

/// `fly --from STORE --evaluation ID` into DIR/fly_ID, which must exit 0; *summary: the flight's
/// summary.json, whose flight time, collisions, emergency stops and each of `same` must equal
/// the stored terms (JSON text).
void FlyAgain(const fs::path& store, const fs::path& dir, const std::string& id,
              const std::string& stored_terms, const std::vector<std::string>& same,
              nlohmann::json* summary) {
  const fs::path out = dir / ("fly_" + id);
  ASSERT_EQ(RunQuadtune("--log-level warn fly --from " + store.string() + " --evaluation " + id +
                            " --no-plot --out " + out.string(),
                        dir / "fly.log"),
            0)
      << ReadText(dir / "fly.log");
  const auto terms = nlohmann::json::parse(stored_terms);
  *summary = nlohmann::json::parse(ReadText(out / "summary.json"));
  EXPECT_EQ((*summary)["flight_time"].get<double>(), terms["t_f"].get<double>());
  EXPECT_EQ((*summary)["collisions"].get<double>(), terms["n_c"].get<double>());
  EXPECT_EQ((*summary)["emergency_stops"].get<double>(), terms["n_e"].get<double>());
  for (const auto& key : same) {
    EXPECT_EQ((*summary)[key].get<double>(), terms[key].get<double>()) << key;
  }
}

TEST(StoredFlights, FlyAgainExportLoadAndReport) {
  fs::path dir;
  const fs::path store = RunInto("quadtune_stored_flights", "tiny.yaml", &dir);
  ASSERT_FALSE(HasFailure());
  const fs::path run = dir / "run";
  const auto flights = Query(store,
                             "SELECT id, terms, value FROM evaluation WHERE kind = 'long' "
                             "ORDER BY id");
  ASSERT_EQ(flights.size(), 3u);  // tiny.yaml: bo_pso, 3 flights
  // Held-out validation flights (tiny.yaml: 2 maps) belong to no trial; they fly again too.
  auto again = flights;
  for (auto& v : Query(store,
                       "SELECT id, terms, value FROM evaluation WHERE kind = 'validation' "
                       "ORDER BY id LIMIT 1")) {
    again.push_back(v);
  }
  ASSERT_EQ(again.size(), 4u);

  // Every stored flight flown again: the same flight time, collisions and emergency stops.
  for (const auto& f : again) {
    SCOPED_TRACE("evaluation " + f[0]);
    const fs::path out = dir / ("fly_" + f[0]);
    nlohmann::json summary;
    FlyAgain(store, dir, f[0], f[1],
             {"plans", "failed_attempts", "compute_units", "jerk_integral", "min_clearance"},
             &summary);
    ASSERT_FALSE(HasFatalFailure());
    EXPECT_EQ(summary["stored"]["evaluation"].get<int>(), std::stoi(f[0]));
    EXPECT_GT(ReadCsv(out / "flight.csv").size(), 20u);
    EXPECT_GT(ReadCsv(out / "plans.csv").size(), 20u);
    EXPECT_FALSE(nlohmann::json::parse(ReadText(out / "obstacles.json"))["cylinders"].empty());
  }
  // Rows that are not flights, and ids not stored, are refused with a clear message.
  const auto short_id = Query(store, "SELECT min(id) FROM evaluation WHERE kind = 'short'");
  ASSERT_EQ(RunQuadtune("fly --from " + store.string() + " --evaluation " + short_id[0][0] +
                            " --out " + (dir / "x").string(),
                        dir / "bad.log"),
            2);
  EXPECT_NE(ReadText(dir / "bad.log").find("short-term re-solve, not a flight"), std::string::npos)
      << ReadText(dir / "bad.log");
  ASSERT_EQ(RunQuadtune("fly --from " + store.string() + " --evaluation 999999 --out " +
                            (dir / "x").string(),
                        dir / "bad.log"),
            2);
  EXPECT_NE(ReadText(dir / "bad.log").find("no evaluation with id 999999"), std::string::npos);

  // Tidy export: one row per evaluation, parameters and terms as columns, values exact.
  ASSERT_EQ(RunQuadtune("export " + store.string() + " --tidy " + (dir / "tidy").string(),
                        dir / "export.log"),
            0)
      << ReadText(dir / "export.log");
  const auto long_rows = ReadCsv(dir / "tidy" / "long_term.csv");
  ASSERT_EQ(long_rows.size(), flights.size());
  for (std::size_t i = 0; i < flights.size(); ++i) {
    EXPECT_EQ(long_rows[i].at("id"), flights[i][0]);
    // The store's text form of a REAL has 15 significant digits; the export keeps every bit.
    EXPECT_NEAR(std::stod(long_rows[i].at("value")), std::stod(flights[i][2]),
                1e-13 * std::abs(std::stod(flights[i][2])));
    EXPECT_EQ(std::stod(long_rows[i].at("terms_t_f")),
              nlohmann::json::parse(flights[i][1])["t_f"].get<double>());
    for (const char* p :
         {"params_v_des", "params_h_pl", "params_t_pl", "map_seed", "flight_seed"}) {
      EXPECT_FALSE(long_rows[i].at(p).empty()) << p;
    }
  }
  const auto n_short = Query(store, "SELECT count(*) FROM evaluation WHERE kind = 'short'");
  const auto n_validation =
      Query(store, "SELECT count(*) FROM evaluation WHERE kind = 'validation'");
  EXPECT_EQ(std::to_string(ReadCsv(dir / "tidy" / "validation.csv").size()), n_validation[0][0]);
  const auto short_rows = ReadCsv(dir / "tidy" / "short_term.csv");
  EXPECT_EQ(std::to_string(short_rows.size()), n_short[0][0]);
  ASSERT_FALSE(short_rows.empty());
  EXPECT_FALSE(short_rows[0].at("params_w_col").empty());
  EXPECT_FALSE(short_rows[0].at("terms_t_c").empty());

  // The Python reader: the same rows as DataFrames.
  const std::string python = "PYTHONPATH='" + std::string(QUADTUNE_SOURCE_DIR) +
                             "/experiments/python' /usr/bin/python3 -c \"import quadtune; "
                             "r = quadtune.load('" +
                             run.string() +
                             "'); "
                             "print(len(r.long), len(r.short), repr(r.long['terms_t_f'].sum()), "
                             "r.long['params_v_des'].notna().all(), r.experiment['name'])\"";
  double t_f_sum = 0.0;
  for (const auto& f : flights) t_f_sum += nlohmann::json::parse(f[1])["t_f"].get<double>();
  const std::string loaded = Capture(python);
  std::istringstream in(loaded);
  std::size_t n_long = 0, n_short_loaded = 0;
  double sum = 0.0;
  std::string all_set, name;
  in >> n_long >> n_short_loaded >> sum >> all_set >> name;
  EXPECT_EQ(n_long, flights.size()) << loaded;
  EXPECT_EQ(std::to_string(n_short_loaded), n_short[0][0]) << loaded;
  EXPECT_NEAR(sum, t_f_sum, 1e-9 * t_f_sum) << loaded;
  EXPECT_EQ(all_set, "True") << loaded;
  EXPECT_EQ(name, "tiny") << loaded;

  // The report: the best flight flown again beside it, the run's flights in the page's data.
  ASSERT_EQ(
      RunQuadtune("--log-level warn report " + run.string() + " --flights 1", dir / "report.log"),
      0)
      << ReadText(dir / "report.log");
  const std::string page = ReadText(run / "report.html");
  EXPECT_GT(page.size(), 1000000u);  // plotly.js and three.js inlined
  EXPECT_EQ(page.find("<script src="), std::string::npos);
  const auto best = Query(store,
                          "SELECT id FROM evaluation WHERE kind = 'long' AND status = 'ok' "
                          "ORDER BY value, id LIMIT 1");
  ASSERT_FALSE(best.empty());
  EXPECT_TRUE(fs::exists(run / "report_flights" / ("run_e" + best[0][0]) / "flight.csv"));
  const auto start = page.find("id=\"qt-data\">");
  ASSERT_NE(start, std::string::npos);
  const auto end = page.find("</script>", start);
  const auto data = nlohmann::json::parse(page.substr(start + 13, end - start - 13));
  EXPECT_EQ(data["runs"]["flights"].size(), flights.size());
  EXPECT_EQ(data["replays"].size(), 1u);
  EXPECT_EQ(data["runs"]["series"][0]["name"], "bo_pso");
}

// Flights of the EGO planner fly again through its plug-in: exit 0 says the same value and every
// term (but the recorded query count); the summary holds them and the stored parameters.
TEST(StoredFlights, EgoFlightsFlyAgainExactly) {
  fs::path dir;
  const fs::path store = RunInto("quadtune_stored_ego_flights", "tiny_ego.yaml", &dir);
  ASSERT_FALSE(HasFailure());
  const auto flights = Query(store,
                             "SELECT id, terms, value, params FROM evaluation WHERE kind = 'long' "
                             "ORDER BY id");
  ASSERT_EQ(flights.size(), 3u);  // tiny_ego.yaml: bo_pso, 3 flights
  for (const auto& f : flights) {
    SCOPED_TRACE("evaluation " + f[0]);
    const fs::path out = dir / ("fly_" + f[0]);
    nlohmann::json summary;
    FlyAgain(store, dir, f[0], f[1],
             {"plans", "failed_attempts", "fallback_plans", "compute_units", "jerk_integral",
              "min_clearance"},
             &summary);
    ASSERT_FALSE(HasFatalFailure());
    EXPECT_EQ(summary["stored"]["evaluation"].get<int>(), std::stoi(f[0]));
    const auto params = nlohmann::json::parse(f[3]);
    ASSERT_FALSE(params.empty());
    for (const auto& [name, value] : params.items()) {
      EXPECT_EQ(summary["params"][name], value) << name;  // the stored parameters were flown
    }
    EXPECT_GT(ReadCsv(out / "flight.csv").size(), 20u);
  }
}

// fly writes summary.json once, with the parameters flown: the planner's defaults and --set;
// into a used folder, it leaves no figure or report of the earlier flight behind.
TEST(StoredFlights, FlySummaryHoldsTheParametersFlown) {
  const fs::path dir = fs::temp_directory_path() / "quadtune_fly_params";
  fs::remove_all(dir);
  fs::create_directories(dir / "f");
  // A used folder: the figure and report of an earlier flight must not stay beside the new logs.
  std::ofstream(dir / "f" / "flight_topdown.png") << "an earlier flight's figure";
  std::ofstream(dir / "f" / "report.html") << "an earlier flight's report";
  ASSERT_EQ(RunQuadtune("--log-level warn fly --planner ego --spacing 3.0 --seed 2 --max-time 3 "
                            "--set v_des=3 --set n_pol=6 --no-plot --out " +
                            (dir / "f").string(),
                        dir / "fly.log"),
            3)  // cut by --max-time
      << ReadText(dir / "fly.log");
  const auto summary = nlohmann::json::parse(ReadText(dir / "f" / "summary.json"));
  EXPECT_EQ(summary["params"]["v_des"].get<double>(), 3.0);
  EXPECT_EQ(summary["params"]["n_pol"].get<double>(), 6.0);
  for (const char* name : {"w_col", "w_dyn", "h_pl", "t_pl"}) {
    EXPECT_TRUE(summary["params"].contains(name)) << name;
  }
  EXPECT_EQ(summary["status"], "timeout");
  EXPECT_EQ(summary["seed"], 2);
  EXPECT_EQ(summary["drone"], "research_1kg");
  EXPECT_FALSE(fs::exists(dir / "f" / "flight_topdown.png"));
  EXPECT_FALSE(fs::exists(dir / "f" / "report.html"));
  EXPECT_TRUE(fs::exists(dir / "f" / "flight.csv"));
}

// A stored flight that no longer flies the same (here: its stored value altered) exits 4, the
// code every --help and the exit-code lists of docs/config.md and docs/hardening.md name.
TEST(StoredFlights, AFlightOtherThanTheStoredOneExitsFour) {
  fs::path dir;
  const fs::path store = RunInto("quadtune_fly_differs", "tiny.yaml", &dir);
  const std::string id =
      Capture("sqlite3 '" + store.string() + "' \"SELECT min(id) FROM evaluation WHERE kind = "
              "'long'\"");
  ASSERT_FALSE(id.empty());
  const std::string trimmed = id.substr(0, id.find('\n'));
  ASSERT_EQ(std::system(("sqlite3 '" + store.string() +
                         "' \"UPDATE evaluation SET value = value + 1 WHERE id = " + trimmed +
                         "\"")
                            .c_str()),
            0);
  EXPECT_EQ(RunQuadtune("--log-level warn fly --from " + store.string() + " --evaluation " +
                            trimmed + " --no-plot --out " + (dir / "f").string(),
                        dir / "fly.log"),
            4)
      << ReadText(dir / "fly.log");
  EXPECT_NE(ReadText(dir / "fly.log").find("differs from the stored one"), std::string::npos)
      << ReadText(dir / "fly.log");
  ASSERT_EQ(RunQuadtune("fly --help", dir / "help.log"), 0);
  EXPECT_NE(ReadText(dir / "help.log").find("4 fly --from flew a flight other than the stored"),
            std::string::npos)
      << ReadText(dir / "help.log");
  for (const char* doc : {"/docs/config.md", "/docs/hardening.md"}) {
    const std::string text = ReadText(std::string(QUADTUNE_SOURCE_DIR) + doc);
    EXPECT_NE(text.find("4 `fly --from` flew a flight other than the stored one"),
              std::string::npos)
        << doc << " does not list exit code 4";
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace quadtune
