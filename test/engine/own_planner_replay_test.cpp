// A planner registered by a program of its own (examples/own_planner's waypoint planner, its
// sources compiled in here as a plug-in author's program compiles them): tuned into a store, then
// every stored flight flown again through the registry and the plug-in (FlyStoredAgain, what
// `quadtune fly --from` and `own_planner --fly` call) — the same value and terms, bit for bit.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/api/planner_registry.hpp"
#include "quadtune/engine/tuning/replay.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "waypoint_planner.hpp"

namespace quadtune::engine {
namespace {

namespace fs = std::filesystem;

/// Ids of the evaluations of `kind` in `store`.
std::vector<std::int64_t> Ids(const std::string& store, const std::string& kind) {
  sqlite3* db = nullptr;
  std::vector<std::int64_t> ids;
  if (sqlite3_open_v2(store.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) return ids;
  sqlite3_stmt* st = nullptr;
  const std::string sql = "SELECT id FROM evaluation WHERE kind = '" + kind + "' ORDER BY id";
  if (sqlite3_prepare_v2(db, sql.c_str(), -1, &st, nullptr) == SQLITE_OK) {
    while (sqlite3_step(st) == SQLITE_ROW) ids.push_back(sqlite3_column_int64(st, 0));
  }
  sqlite3_finalize(st);
  sqlite3_close(db);
  return ids;
}

TEST(OwnPlannerReplay, StoredFlightsOfAProgramsPlannerFlyAgainExactly) {
  if (!FindPlanner("waypoint")) own_planner::RegisterWaypointPlanner();
  const fs::path dir = fs::temp_directory_path() / "quadtune_own_planner_replay";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Experiment e = Experiment::LoadFile(std::string(QUADTUNE_SOURCE_DIR) +
                                            "/examples/own_planner/waypoint.yaml");
  ASSERT_EQ(e.planner_type, "waypoint");
  RunOptions options;
  options.store_path = (dir / "results.sqlite").string();
  (void)RunExperiment(e, options);

  std::vector<std::int64_t> flights = Ids(options.store_path, "long");
  ASSERT_EQ(flights.size(), 3u);  // waypoint.yaml: 3 flights
  const std::vector<std::int64_t> validation = Ids(options.store_path, "validation");
  ASSERT_FALSE(validation.empty());
  flights.push_back(validation.front());
  for (const std::int64_t id : flights) {
    SCOPED_TRACE("evaluation " + std::to_string(id));
    const fs::path out = dir / ("fly_" + std::to_string(id));
    const Replay replay = FlyStoredAgain(options.store_path, id, out.string());
    EXPECT_TRUE(replay.same) << (replay.differences.empty() ? "" : replay.differences.front());
    EXPECT_EQ(replay.objective.value, replay.stored.row.value);
    const auto stored_terms = nlohmann::json::parse(replay.stored.row.terms);
    for (const auto& [name, value] : replay.objective.terms) {
      if (name != "queries") {
        EXPECT_EQ(value, stored_terms.at(name).get<double>()) << name;
      }
    }
    // The closed loop's log, and summary.json written once with the stored row beside it.
    EXPECT_TRUE(replay.record.logged);
    for (const char* file : {"flight.csv", "plans.csv", "plan_steps.csv", "obstacles.json",
                             "layout.yaml"}) {
      EXPECT_TRUE(fs::exists(out / file)) << file;
    }
    const auto summary = nlohmann::json::parse(std::ifstream(out / "summary.json"));
    EXPECT_EQ(summary["flight_time"].get<double>(), stored_terms["t_f"].get<double>());
    EXPECT_EQ(summary["stored"]["evaluation"].get<std::int64_t>(), id);
    const auto stored_params = nlohmann::json::parse(replay.stored.row.params);
    ASSERT_FALSE(stored_params.empty());
    for (const auto& [name, value] : stored_params.items()) {
      EXPECT_EQ(summary["params"][name], value) << name;  // the row's parameters were flown
    }
  }
}

}  // namespace
}  // namespace quadtune::engine
