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
#include <string>
#include <vector>

#include "commands.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/text_file.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/api/planner_registry.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/world.hpp"
#include "quadtune/planning/parameters.hpp"
#include "quadtune/planning/trajectory_backend.hpp"
#include "quadtune/sim/flight.hpp"
#include "quadtune/sim/scenario.hpp"
#include "result_dir.hpp"
#include "stored_flight.hpp"

namespace quadtune::cli {
namespace {

// The achieved value of what the layout's spacing means: the mean free gap (zones weighted by
// their obstacle counts) under `free_gap`, else the mean nearest-neighbour centre distance.
double AchievedSpacing(const layout::Layout& layout) {
  if (layout.options.density != layout::DensityDefinition::kFreeGap) {
    return layout.stats.overall.mean;
  }
  double sum = 0.0;
  double count = 0.0;
  for (const auto& z : layout.stats.zones) {
    sum += z.gap.mean * static_cast<double>(z.gap.count);
    count += static_cast<double>(z.gap.count);
  }
  return count > 0.0 ? sum / count : 0.0;
}

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

/// Applies "name=value" overrides to the planner parameters.
planning::PlannerParams ParseOverrides(const std::vector<std::string>& items) {
  planning::PlannerParams params;
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
  }
  params.Validate("--set");
  return params;
}

std::atomic<bool> g_fly_interrupted{false};
void OnFlySignal(int) { g_fly_interrupted.store(true); }

int RunFly(const FlyArgs& a) {
  if (!a.from.empty() || a.evaluation >= 0) {
    if (a.from.empty() || a.evaluation < 0) {
      throw ConfigError("", a.from.empty() ? "--from" : "--evaluation",
                        "--from STORE and --evaluation ID go together");
    }
    const int status = FlyStored(a.from, a.evaluation, a.out);
    if (a.plot && RunPlotScript("flight '" + a.out + "'") != 0) return 1;
    return status;
  }
  const std::shared_ptr<const planning::TrajectoryBackend> backend =
      engine::BuildClosedLoopBackend(a.planner, "", "--planner");
  CheckOutputDir(a.out, "--out");
  const planning::PlannerParams params = ParseOverrides(a.set);
  const physics::DroneDescription drone = physics::LoadDroneDescription(AssetPath(a.drone));
  layout::Layout layout;
  if (!a.layout_file.empty()) {
    layout = layout::Layout::Load(a.layout_file);
  } else {
    layout::LayoutOptions options;
    if (!a.layout_options_file.empty()) {
      options = layout::LayoutOptions::LoadFile(a.layout_options_file);
    } else {
      options = ForestOptions(a.spacing);
    }
    layout = layout::GenerateLayout(options, a.seed);
  }
  physics::WorldOptions world_options;
  if (!a.world_file.empty()) {
    world_options = physics::WorldOptions::FromYaml(YamlMap::LoadFile(a.world_file));
  }
  world_options.collision_response = physics::CollisionResponse::kPassThrough;
  const std::optional<sim::MissionKind> mission_kind = FromString<sim::MissionKind>(a.mission);
  if (!mission_kind) throw ConfigError("", "--mission", "unknown mission '" + a.mission + "'");
  const sim::Scenario scenario =
      sim::Scenario::OverLayout(layout, *mission_kind, drone, world_options, a.seed);
  sim::FlightOptions options;
  options.max_time = a.max_time;

  spdlog::info("flying {} with {} obstacles (spacing {:.2f} m achieved {:.2f} m), drone {}",
               a.mission, layout.obstacles.size(), layout.options.spacing,
               AchievedSpacing(layout), drone.name);
  std::shared_ptr<physics::World> world;
  sim::MakeWorld(scenario, world);
  const sim::Mission& mission = scenario.mission;
  // SIGINT/SIGTERM end the flight at its next tick: nothing is written, exit 130.
  std::signal(SIGINT, OnFlySignal);
  std::signal(SIGTERM, OnFlySignal);
  sim::FlightHooks hooks;
  hooks.cancelled = [] { return g_fly_interrupted.load(); };
  const sim::FlightResult result = sim::Fly(*world, mission, params, options, *backend, hooks);
  if (g_fly_interrupted.load()) {
    spdlog::error("fly interrupted; nothing written");
    return 130;
  }
  const auto& m = result.metrics;

  std::filesystem::create_directories(a.out);
  sim::WriteFlightFiles(a.out, result, layout.obstacles, mission);
  layout.Save((std::filesystem::path(a.out) / "layout.yaml").string());
  {  // Record the layout's density beside the metrics, for summaries across densities.
    const auto path = std::filesystem::path(a.out) / "summary.json";
    nlohmann::json summary = nlohmann::json::parse(std::ifstream(path));
    summary["spacing_target"] = layout.options.spacing;
    summary["density_definition"] = quadtune::ToString(layout.options.density);
    summary["spacing_achieved"] = AchievedSpacing(layout);
    summary["obstacles"] = layout.obstacles.size();
    summary["seed"] = a.seed;
    summary["drone"] = drone.name;
    std::ofstream(path) << summary.dump(1) << '\n';
  }

  spdlog::info(
      "status {} ({}), flight time t_f {:.2f} s, collisions n_c {}, emergency stops n_e {}",
      sim::ToString(m.status), m.message.empty() ? "ok" : m.message, m.flight_time, m.collisions,
      m.emergency_stops);
  spdlog::info(
      "plans {} (failed {}, stop-and-go fallbacks {}, failed attempts n_s {}), solve time "
      "t_c mean {:.2f} ms max {:.2f} ms, max tracking error {:.3f} m, min clearance "
      "{:.2f} m, mean speed {:.2f} m/s",
      m.plans, m.failed_plans, m.fallback_plans, m.failed_attempts, 1e3 * m.mean_solve_time,
      1e3 * m.max_solve_time, m.max_tracking_error, m.min_clearance, m.mean_speed);
  spdlog::info("simulated {:.1f} s in {:.2f} s wall time ({:.0f}x real time)", m.flight_time,
               m.wall_time, m.wall_time > 0 ? m.flight_time / m.wall_time : 0.0);
  spdlog::info("wrote {}/flight.csv, plans.csv, summary.json, obstacles.json, layout.yaml", a.out);
  if (a.plot) {
    if (RunPlotScript("flight '" + a.out + "'") != 0) return 1;
    spdlog::info("figure: {}/flight_topdown.png", a.out);
  }
  return m.status == sim::FlightStatus::kCompleted ? 0 : 3;
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
