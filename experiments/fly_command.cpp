#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include "commands.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/api/planner_registry.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/tuning/replay.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/world.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/trajectory_backend.hpp"
#include "quadtune/sim/flight.hpp"
#include "result_dir.hpp"
#include "stored_flight.hpp"

namespace quadtune::cli {
namespace {

struct FlyArgs {
  std::string drone = "drones/research_1kg.yaml";
  std::string layout_file;
  std::string layout_options_file;
  std::string world_file;
  double spacing = 1.3;
  std::uint64_t seed = 1;
  std::vector<std::string> set;
  std::string out = "results/flight";
  std::string mission = "go_and_return";  ///< the experiment files' spelling
  double max_time = 120.0;
  std::string planner = "ipopt";
  bool plot = true;
  std::string from;  ///< a results store: fly its evaluation `evaluation` again
  std::int64_t evaluation = -1;
};

/// The "name=value" overrides of the planner parameters, checked as the closed loop flies them.
engine::ParamValues ParseOverrides(const std::vector<std::string>& items) {
  planning::PlannerParams params;
  engine::ParamValues values;
  for (const auto& item : items) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) {
      throw ConfigError("--set", item, "expected NAME=VALUE, e.g. --set v_des=3.0");
    }
    const std::string name = item.substr(0, eq);
    double value = 0.0;
    try {
      std::size_t used = 0;
      value = std::stod(item.substr(eq + 1), &used);
      if (used != item.size() - eq - 1) throw std::invalid_argument("trailing characters");
    } catch (const std::exception&) {
      throw ConfigError("--set", name, "'" + item.substr(eq + 1) + "' is not a number");
    }
    try {
      params.Set(name, value);
    } catch (const ConfigError& e) {
      throw ConfigError("--set", "", e.what());  // "--set: NAME: unknown planner parameter; ..."
    }
    values[name] = value;
  }
  params.Validate("--set");
  return values;
}

/// The closed-loop planner `--planner` names, as the engine flies it: the registry's back end in
/// a BackendPlanner over the flags' drone, layout generator, world, mission and time limit.
engine::BackendPlanner FlyPlanner(const FlyArgs& a,
                                  std::shared_ptr<const planning::TrajectoryBackend> backend) {
  engine::ClosedLoopOptions o;
  o.drone = physics::LoadDroneDescription(AssetPath(a.drone));
  if (!a.layout_options_file.empty()) {
    o.layout = layout::LayoutOptions::LoadFile(a.layout_options_file);
  } else if (a.layout_file.empty()) {
    o.layout = ForestOptions(a.spacing);
  }  // else the saved layout is flown (MapOf)
  if (!a.world_file.empty()) {
    o.world = physics::WorldOptions::FromYaml(YamlMap::LoadFile(a.world_file));
  }
  o.world.collision_response = physics::CollisionResponse::kPassThrough;
  const std::optional<sim::MissionKind> mission = FromString<sim::MissionKind>(a.mission);
  if (!mission) throw ConfigError("", "--mission", "unknown mission '" + a.mission + "'");
  o.mission = *mission;
  o.flight.max_time = a.max_time;
  return engine::BackendPlanner(a.planner, std::move(o), std::move(backend));
}

/// A number among a flight's summary facts (0 when absent).
double Fact(const engine::FlightRecord& r, const std::string& name) {
  const auto it = r.log.find(name);
  if (it == r.log.end()) return 0.0;
  if (const auto* i = std::get_if<std::int64_t>(&it->second)) return static_cast<double>(*i);
  const auto* d = std::get_if<double>(&it->second);
  return d ? *d : 0.0;
}

/// Removes from `out` what an earlier flight there left and this one did not write again: the
/// figure and report drawn from the earlier logs, and, for a flight that keeps no log, those
/// logs; so that every file beside the new summary.json is of the new flight.
void RemoveStaleOutputs(const std::string& out, bool logged) {
  namespace fs = std::filesystem;
  std::vector<std::string> stale = {"flight_topdown.png", "report.html"};
  if (!logged) {
    stale.insert(stale.end(), {"flight.csv", "plans.csv", "obstacles.json", "layout.yaml"});
  }
  for (const auto& name : stale) {
    std::error_code ignored;
    fs::remove(fs::path(out) / name, ignored);
  }
}

std::atomic<bool> g_fly_interrupted{false};
void OnFlySignal(int) { g_fly_interrupted.store(true); }

/// `fly --from STORE --evaluation ID`: exit 0 when the stored flight flies again the same, 4
/// when it does not.
int RunFlyStored(const FlyArgs& a) {
  if (a.from.empty() || a.evaluation < 0) {
    throw ConfigError("", a.from.empty() ? "--from" : "--evaluation",
                      "--from STORE and --evaluation ID go together");
  }
  const engine::Replay replay = FlyStored(a.from, a.evaluation, a.out);
  RemoveStaleOutputs(a.out, replay.record.logged);
  if (!replay.record.logged) {
    spdlog::info("the planner keeps no flight log; wrote {}/summary.json", a.out);
  } else if (a.plot && RunPlotScript("flight '" + a.out + "'") != 0) {
    return 1;
  }
  return replay.same ? 0 : 4;
}

void LogFlight(const FlyArgs& a, const engine::FlightRecord& r) {
  spdlog::info("{} with {} obstacles (spacing {:.2f} m achieved {:.2f} m), seed {}", a.mission,
               Fact(r, "obstacles"), Fact(r, "spacing_target"), Fact(r, "spacing_achieved"),
               a.seed);
  spdlog::info("{}, flight time t_f {:.2f} s, collisions n_c {}, emergency stops n_e {}",
               r.message, r.flight_time, r.collisions, r.emergency_stops);
  spdlog::info(
      "plans {} (failed {}, stop-and-go fallbacks {}, failed attempts n_s {}), solve time "
      "t_c mean {:.2f} ms max {:.2f} ms, max tracking error {:.3f} m, min clearance "
      "{:.2f} m, mean speed {:.2f} m/s",
      r.plans, r.failed_plans, r.fallback_plans, r.failed_attempts,
      1e3 * Fact(r, "mean_solve_time"), 1e3 * Fact(r, "max_solve_time"),
      Fact(r, "max_tracking_error"), r.min_clearance, Fact(r, "mean_speed"));
  spdlog::info("simulated {:.1f} s in {:.2f} s wall time ({:.0f}x real time)", r.flight_time,
               r.wall_time, r.wall_time > 0 ? r.flight_time / r.wall_time : 0.0);
  spdlog::info("wrote {}/flight.csv, plans.csv, summary.json, obstacles.json, layout.yaml", a.out);
}

int RunFly(const FlyArgs& a) {
  if (!a.from.empty() || a.evaluation >= 0) return RunFlyStored(a);
  std::shared_ptr<const planning::TrajectoryBackend> backend =
      engine::BuildClosedLoopBackend(a.planner, "", "--planner");
  CheckOutputDir(a.out, "--out");
  engine::FlightRequest request;
  request.params = ParseOverrides(a.set);
  request.seed = a.seed;
  const engine::BackendPlanner planner = FlyPlanner(a, std::move(backend));
  request.map = a.layout_file.empty() ? planner.PrepareMap(a.seed)
                                      : planner.MapOf(layout::Layout::Load(a.layout_file));
  spdlog::info("flying {} with the {} planner, drone {}", a.mission, a.planner,
               planner.options().drone.name);
  // SIGINT/SIGTERM end the flight at its next tick: nothing is written, exit 130.
  std::signal(SIGINT, OnFlySignal);
  std::signal(SIGTERM, OnFlySignal);
  request.cancelled = [] { return g_fly_interrupted.load(); };
  const engine::FlightRecord r =
      engine::FlyWithLog(planner, std::move(request), a.out, {{"seed", a.seed}});
  if (g_fly_interrupted.load()) {
    spdlog::error("fly interrupted; nothing written");
    return 130;
  }
  if (r.status == engine::EvalStatus::kFailed && !r.logged) {
    throw std::runtime_error("fly: " + r.message);  // the planner threw (FlyOnPool)
  }
  RemoveStaleOutputs(a.out, r.logged);
  LogFlight(a, r);
  if (a.plot) {
    if (RunPlotScript("flight '" + a.out + "'") != 0) return 1;
    spdlog::info("figure: {}/flight_topdown.png", a.out);
  }
  return r.completed ? 0 : 3;
}

}  // namespace

layout::LayoutOptions ForestOptions(double spacing) {
  if (!(spacing > 0.0) || !std::isfinite(spacing)) {
    throw ConfigError("--spacing", "", "expected a positive spacing (m)");
  }
  // forest_1p3.yaml for 1.3 m: the spacing with one decimal, the point written as 'p'.
  const long tenths = std::lround(10.0 * spacing);
  const std::string name =
      "layouts/forest_" + std::to_string(tenths / 10) + "p" + std::to_string(tenths % 10) + ".yaml";
  const bool shipped =
      std::abs(10.0 * spacing - static_cast<double>(tenths)) < 1e-9 && PathExists(AssetPath(name));
  layout::LayoutOptions options =
      layout::LayoutOptions::LoadFile(AssetPath(shipped ? name : "layouts/forest_1p3.yaml"));
  if (!shipped) {
    // forest_1p3.yaml's mix at another free gap: its min_gap keeps its ratio to the spacing.
    options.min_gap *= spacing / options.spacing;
  }
  options.spacing = spacing;
  options.Validate("--spacing");
  return options;
}

void RegisterFly(CLI::App& app, int& exit_code) {
  static FlyArgs args;
  auto* cmd = app.add_subcommand(
      "fly", "fly one closed-loop mission (physics, sensing, mapping, planning) and write its log");
  cmd->add_option("--drone", args.drone,
                  "drone description (YAML; relative paths also searched "
                  "in assets/)")
      ->capture_default_str();
  cmd->add_option("--layout", args.layout_file, "a saved layout (YAML) to fly through");
  cmd->add_option("--layout-options", args.layout_options_file,
                  "layout generator options (YAML) to generate from");
  cmd->add_option("--spacing", args.spacing,
                  "average obstacle spacing (m) when no layout is "
                  "given: the shipped forest of that spacing "
                  "(assets/layouts/forest_*.yaml), else "
                  "forest_1p3.yaml's mix at that spacing")
      ->capture_default_str();
  cmd->add_option("--seed", args.seed, "seed of the layout and the world")
      ->capture_default_str()
      ->check(SeedValidator());
  cmd->add_option("--world", args.world_file, "world options (YAML): rates, wind, noise, …");
  cmd->add_option("--set", args.set,
                  "planner parameter override NAME=VALUE (repeatable), e.g. "
                  "--set v_des=3 --set n_pol=6");
  cmd->add_option("--mission", args.mission,
                  "go_and_return or go_to (as planner.mission in an "
                  "experiment file)")
      ->transform(
          [](std::string text) {  // go-and-return and go-to are read the same
            std::replace(text.begin(), text.end(), '-', '_');
            return text;
          },
          "", "")
      ->check(CLI::IsMember(EnumNameList<sim::MissionKind>()))
      ->capture_default_str();
  cmd->add_option("--planner", args.planner,
                  "planner type from the planner registry, flown in the closed loop (registered: " +
                      fmt::format("{}", fmt::join(engine::ClosedLoopPlanners(), ", ")) +
                      "; ego is EGO-Planner's back end)")
      ->capture_default_str();
  cmd->add_option("--max-time", args.max_time, "flight time limit (s)")->capture_default_str();
  cmd->add_option("--out", args.out, "output directory")->capture_default_str();
  AddNoPlotFlag(*cmd, args.plot, "skip the figure");
  cmd->add_option("--from", args.from,
                  "a results store (results.sqlite): fly one of its stored "
                  "flights again exactly, with full logs");
  cmd->add_option("--evaluation", args.evaluation, "with --from: the evaluation id to fly");
  cmd->callback([&exit_code] { exit_code = RunFly(args); });
}

}  // namespace quadtune::cli
