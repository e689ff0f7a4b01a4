// own_planner: registers the waypoint planner (waypoint_planner.hpp) as `planner.type: waypoint`
// and tunes it with quadtune's engine, or flies one of its stored flights again.
//
//   own_planner EXPERIMENT.yaml RESULTS.sqlite
//   own_planner --fly RESULTS.sqlite ID OUT
//
// The first loads the experiment (any registered planner type, this program's included), runs it
// with engine::RunExperiment into the SQLite store and prints the best value of every trial. The
// second flies stored evaluation ID again with engine::FlyStoredAgain (the planner the stored
// configuration builds, through the registry), writes its log into the folder OUT and exits 0
// when the flight is the stored one, 4 when it differs (as `quadtune fly --from`). The installed
// `quadtune` program draws the figures and the report of the store (`quadtune plot run DIR`,
// `quadtune report DIR`) and the 3-D replay of a flight flown again (`quadtune report OUT`); it
// cannot fly this program's planner itself.

#include <cstdint>
#include <exception>
#include <iostream>
#include <string>

#include "quadtune/common/error.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/tuning/replay.hpp"
#include "quadtune/engine/tuning/tuner.hpp"
#include "waypoint_planner.hpp"

namespace {

namespace engine = quadtune::engine;

int Tune(const std::string& experiment_file, const std::string& store) {
  const engine::Experiment experiment = engine::Experiment::LoadFile(experiment_file);
  engine::RunOptions options;
  options.store_path = store;
  const engine::RunSummary summary = engine::RunExperiment(experiment, options);
  for (const auto& trial : summary.trials) {
    std::cout << trial.method << " repeat " << trial.repeat << ": best f_l " << trial.best_value
              << "\n";
  }
  return 0;
}

int FlyAgain(const std::string& store, const std::string& id, const std::string& out) {
  const engine::Replay replay = engine::FlyStoredAgain(store, std::stoll(id), out);
  std::cout << "evaluation " << id << ": f_l " << replay.objective.value << " (stored "
            << replay.stored.row.value << "), t_f " << replay.record.flight_time << " s\n";
  for (const auto& d : replay.differences) std::cout << "differs: " << d << "\n";
  return replay.same ? 0 : 4;
}

}  // namespace

int main(int argc, char** argv) {
  const bool fly = argc == 5 && std::string(argv[1]) == "--fly";
  if (argc != 3 && !fly) {
    std::cerr << "usage: own_planner EXPERIMENT.yaml RESULTS.sqlite\n"
                 "       own_planner --fly RESULTS.sqlite ID OUT\n";
    return 2;
  }
  // Drone and layout files named in the experiment are found in the installed package's assets.
  engine::SetAssetDirs({OWN_PLANNER_ASSETS});
  try {
    own_planner::RegisterWaypointPlanner();
    return fly ? FlyAgain(argv[2], argv[3], argv[4]) : Tune(argv[1], argv[2]);
  } catch (const quadtune::ConfigError& e) {
    std::cerr << "own_planner: " << e.what() << "\n";
    return 1;
  } catch (const std::exception& e) {  // e.g. an ID that is not a number
    std::cerr << "own_planner: " << e.what() << "\n";
    return 1;
  }
}
