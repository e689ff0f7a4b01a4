// own_planner: registers the waypoint planner (waypoint_backend.hpp) as `planner.type: waypoint`
// and tunes it with quadtune's engine.
//
//   own_planner EXPERIMENT.yaml RESULTS.sqlite
//
// Loads the experiment (any registered planner type, this program's included), runs it with
// engine::RunExperiment into the SQLite store and prints the best value of every trial.

#include <exception>
#include <iostream>
#include <memory>
#include <string>

#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/api/planner_registry.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "waypoint_backend.hpp"

namespace {

namespace engine = quadtune::engine;

// `planner.type: waypoint`: the closed-loop keys of the ipopt planner (drone, layout, mission,
// ...) and an optional `waypoint:` map of WaypointOptions.
engine::Planner BuildWaypoint(const quadtune::YamlMap& planner, const std::string& base_dir) {
  engine::ClosedLoopOptions loop = engine::ClosedLoopOptions::FromYaml(planner, base_dir,
                                                                           {"waypoint"});
  const quadtune::YamlMap w = planner.Map("waypoint", true);
  w.RejectUnknownKeys({"check_dt", "limit_tolerance", "min_piece_time"});
  own_planner::WaypointOptions o;
  o.check_dt = w.Number("check_dt", o.check_dt);
  o.limit_tolerance = w.Number("limit_tolerance", o.limit_tolerance);
  o.min_piece_time = w.Number("min_piece_time", o.min_piece_time);
  auto backend = std::make_shared<const own_planner::WaypointBackend>(o, planner.file());
  return engine::Planner{engine::BackendPlanner{"waypoint", std::move(loop), std::move(backend)}};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: own_planner EXPERIMENT.yaml RESULTS.sqlite\n";
    return 2;
  }
  // Drone and layout files named in the experiment are found in the installed package's assets.
  engine::SetAssetDirs({OWN_PLANNER_ASSETS});
  try {
    engine::RegisterPlanner("waypoint", BuildWaypoint, engine::BackendPlanner::Schema());
    const engine::Experiment experiment = engine::Experiment::LoadFile(argv[1]);
    engine::RunOptions options;
    options.store_path = argv[2];
    const engine::RunSummary summary = engine::RunExperiment(experiment, options);
    for (const auto& trial : summary.trials) {
      std::cout << trial.method << " repeat " << trial.repeat << ": best f_l "
                << trial.best_value << "\n";
    }
  } catch (const quadtune::ConfigError& e) {
    std::cerr << "own_planner: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
