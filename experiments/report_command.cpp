// `quadtune report DIR`: one self-contained HTML page (DIR/report.html) of a run, a study or a
// flight directory. Stored flights are flown again into DIR/report_flights/ for the 3-D replay;
// the page itself is written by experiments/report/quadtune_report.py (Debian's python3 with
// numpy, scipy and yaml) with three.js and plotly.js inlined from experiments/report/js/node_modules.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.hpp"
#include "result_dir.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/api/planner_registry.hpp"
#include "stored_flight.hpp"

namespace quadtune::cli {
namespace {

namespace fs = std::filesystem;

struct ReportArgs {
  std::string dir;
  int flights = 3;
};

/// Every results store under `dir` (the run's own, or each stage of a study), sorted.
std::vector<fs::path> StoresUnder(const fs::path& dir) {
  std::vector<fs::path> stores;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().filename() == "results.sqlite" &&
        entry.path().string().find("report_flights") == std::string::npos) {
      stores.push_back(entry.path());
    }
  }
  std::sort(stores.begin(), stores.end());
  return stores;
}

/// The stored configuration's planner.type when this program has not registered it (a planner
/// of one's own, registered by one's own program), else "".
std::string UnregisteredPlannerType(const fs::path& store, std::int64_t id) {
  try {
    const engine::StoredFlight f = engine::LoadStoredFlight(store.string(), id);
    const std::string type =
        YamlMap::FromString(f.config, store.string()).Map("planner", true).String("type", "ipopt");
    return engine::FindPlanner(type) ? std::string() : type;
  } catch (const ConfigError&) {
    return {};
  }
}

/// Warns that stored evaluation `id` is not replayed: `why`, or, for a planner type this
/// program has not registered, that the program which registers it flies it again.
void WarnNoReplay(const fs::path& store, std::int64_t id, const std::string& why) {
  const std::string type = UnregisteredPlannerType(store, id);
  if (type.empty()) {
    spdlog::warn("no replay of {} evaluation {}: {}", store.string(), id, why);
    return;
  }
  spdlog::warn(
      "no 3-D replay in the report: planner.type '{}' of {} is not registered in this program "
      "(registered: {}); the program that registers it flies a stored flight again, e.g. the "
      "own-planner example's `own_planner --fly {} {} OUT`, and `quadtune report OUT` shows "
      "that flight",
      type, store.string(), fmt::format("{}", fmt::join(engine::RegisteredPlanners(), ", ")),
      store.string(), id);
}

/// Folder name of a replayed flight: the store's folder relative to the report, and the id.
std::string FlightFolder(const fs::path& dir, const fs::path& store, std::int64_t id) {
  std::string tag = fs::relative(store.parent_path(), dir).generic_string();
  std::replace(tag.begin(), tag.end(), '/', '_');
  if (tag == ".") tag = "run";
  return tag + "_e" + std::to_string(id);
}

int Report(const ReportArgs& a) {
  const fs::path dir(a.dir);
  const bool flight_dir =
      PathExists((dir / "flight.csv").string()) && PathExists((dir / "summary.json").string());
  if (!flight_dir) {
    const std::vector<fs::path> stores = StoresUnder(dir);
    if (stores.empty()) {
      throw ConfigError(a.dir, "DIR",
                        "holds no results.sqlite (a `quadtune run` or `study` output) and no "
                        "flight.csv (a `quadtune fly` output)");
    }
    // Each store's best flight per method, taken store by store in turn, at most --flights.
    std::vector<std::vector<std::int64_t>> best;
    for (const auto& s : stores) best.push_back(BestFlightIds(s.string(), a.flights));
    std::vector<std::pair<fs::path, std::int64_t>> chosen;
    for (std::size_t rank = 0; static_cast<int>(chosen.size()) < a.flights; ++rank) {
      bool any = false;
      for (std::size_t s = 0; s < stores.size(); ++s) {
        if (rank < best[s].size() && static_cast<int>(chosen.size()) < a.flights) {
          chosen.emplace_back(stores[s], best[s][rank]);
          any = true;
        }
      }
      if (!any) break;
    }
    fs::remove_all(dir / "report_flights");
    for (const auto& [store, id] : chosen) {
      const fs::path out = dir / "report_flights" / FlightFolder(dir, store, id);
      try {
        const engine::Replay replay = FlyStored(store.string(), id, out.string());
        if (!replay.record.logged) {  // e.g. a toy-planner store: charts only
          spdlog::warn("no replay of {} evaluation {}: its planner keeps no flight log",
                       store.string(), id);
          fs::remove_all(out);
          break;
        }
        if (!replay.same) {
          spdlog::warn("the replay of {} evaluation {} differs from the stored flight",
                       store.string(), id);
        }
      } catch (const ConfigError& e) {  // e.g. a planner type this program has not registered
        WarnNoReplay(store, id, e.what());
        break;
      }
    }
  }
  if (RunPythonScript("experiments/report/quadtune_report.py", "QUADTUNE_REPORT_SCRIPT",
                      "'" + a.dir + "'") != 0) {
    return 1;
  }
  spdlog::info("report: {}", (dir / "report.html").string());
  return 0;
}

}  // namespace

int WriteReport(const std::string& dir, int flights) { return Report(ReportArgs{dir, flights}); }

int DrawFiguresAndReport(const std::string& plot_args, const std::string& dir) {
  const int figures = RunPlotScript(plot_args);
  int report = 1;
  try {
    report = WriteReport(dir);
  } catch (const std::exception& ex) {
    spdlog::error("report: {}", ex.what());
  }
  return figures == 0 && report == 0 ? 0 : 1;
}

void RegisterReport(CLI::App& app, int& exit_code) {
  static ReportArgs args;
  auto* cmd = app.add_subcommand(
      "report",
      "write DIR/report.html: held-out validation, tuned parameters, convergence, final "
      "values, f_l distributions, Sobol' importance, slices, evaluations and a 3-D replay of "
      "stored flights (opens offline)");
  cmd->add_option("DIR", args.dir, "a `quadtune run`, `study` or `fly` output directory")
      ->required()
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--flights", args.flights,
                  "stored flights to fly again for the 3-D replay "
                  "(each method's best first)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->callback([&exit_code] {
    // Held while the report is written: a run, study or second report into DIR is refused
    // meanwhile, and this report waits for none of them (refused while one writes).
    ResultDirPolicy lock;
    lock.lock_only = true;
    lock.key = "DIR";
    const ResultDir held(args.dir, lock);
    exit_code = Report(args);
  });
}

}  // namespace quadtune::cli
