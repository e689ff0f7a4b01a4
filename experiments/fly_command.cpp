#include <spdlog/spdlog.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "commands.hpp"
#include "result_dir.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/world.hpp"
#include "quadtune/planning/flight.hpp"
#include "quadtune/planning/parameters.hpp"

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
  std::string mission = "go-and-return";
  double max_time = 120.0;
  bool plot = true;
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

int RunFly(const FlyArgs& a) {
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
      options.spacing = a.spacing;
      options.Validate("--spacing");
    }
    layout = layout::GenerateLayout(options, a.seed);
  }
  physics::WorldOptions world_options;
  if (!a.world_file.empty()) {
    world_options = physics::WorldOptions::FromYaml(YamlMap::LoadFile(a.world_file));
  }
  world_options.seed = a.seed;
  world_options.collision_response = physics::CollisionResponse::kPassThrough;

  const planning::Mission mission =
      a.mission == "go-to" ? planning::Mission::GoTo(layout.start_W(), layout.goal_W())
                           : planning::Mission::GoAndReturn(layout.start_W(), layout.goal_W());
  planning::FlightOptions options;
  options.max_time = a.max_time;
  const planning::TrajectoryOptimizer optimizer;

  spdlog::info("flying {} with {} obstacles (spacing {:.2f} m achieved {:.2f} m), drone {}",
               a.mission, layout.obstacles.size(), layout.options.spacing,
               layout.stats.overall.mean, drone.name);
  physics::World world(layout.obstacles, drone, world_options,
                       physics::DroneState::Hover(drone, mission.start_W, mission.start_yaw));
  const planning::FlightResult result = planning::Fly(world, mission, params, options, optimizer);
  const auto& m = result.metrics;

  std::filesystem::create_directories(a.out);
  planning::WriteFlightFiles(a.out, result, layout.obstacles, mission);
  layout.Save((std::filesystem::path(a.out) / "layout.yaml").string());
  {  // Record the layout's density beside the metrics, for summaries across densities.
    const auto path = std::filesystem::path(a.out) / "summary.json";
    nlohmann::json summary = nlohmann::json::parse(std::ifstream(path));
    summary["spacing_target"] = layout.options.spacing;
    summary["spacing_achieved"] = layout.stats.overall.mean;
    summary["obstacles"] = layout.obstacles.size();
    summary["seed"] = a.seed;
    summary["drone"] = drone.name;
    std::ofstream(path) << summary.dump(1) << '\n';
  }

  spdlog::info("status {} ({}), flight time t_f {:.2f} s, collisions n_c {}, emergency stops n_e {}",
               planning::ToString(m.status), m.message.empty() ? "ok" : m.message, m.flight_time,
               m.collisions, m.emergency_stops);
  spdlog::info("plans {} (failed {}, stop-and-go fallbacks {}, failed attempts n_s {}), solve time "
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
  return m.status == planning::FlightStatus::kCompleted ? 0 : 3;
}

}  // namespace

void RegisterFly(CLI::App& app, int& exit_code) {
  static FlyArgs args;
  auto* cmd = app.add_subcommand(
      "fly", "fly one closed-loop mission (physics, sensing, mapping, planning) and write its log");
  cmd->add_option("--drone", args.drone, "drone description (YAML; relative paths also searched "
                                         "in assets/)")->capture_default_str();
  cmd->add_option("--layout", args.layout_file, "a saved layout (YAML) to fly through");
  cmd->add_option("--layout-options", args.layout_options_file,
                  "layout generator options (YAML) to generate from");
  cmd->add_option("--spacing", args.spacing, "target mean obstacle spacing (m) when no layout "
                                             "is given")->capture_default_str();
  cmd->add_option("--seed", args.seed, "seed of the layout and the world")
      ->capture_default_str()
      ->check(SeedValidator());
  cmd->add_option("--world", args.world_file, "world options (YAML): rates, wind, noise, …");
  cmd->add_option("--set", args.set, "planner parameter override NAME=VALUE (repeatable), e.g. "
                                     "--set v_des=3 --set n_pol=6");
  cmd->add_option("--mission", args.mission, "go-and-return or go-to")
      ->check(CLI::IsMember({"go-and-return", "go-to"}))->capture_default_str();
  cmd->add_option("--max-time", args.max_time, "flight time limit (s)")->capture_default_str();
  cmd->add_option("--out", args.out, "output directory")->capture_default_str();
  cmd->add_flag("!--no-plot", args.plot, "skip the figure");
  cmd->callback([&exit_code] { exit_code = RunFly(args); });
}

}  // namespace quadtune::cli
