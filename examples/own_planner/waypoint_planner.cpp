#include "waypoint_planner.hpp"

#include <memory>
#include <utility>

#include "quadtune/engine/api/planner_registry.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "waypoint_backend.hpp"

namespace own_planner {

namespace engine = quadtune::engine;

engine::Planner BuildWaypointPlanner(const quadtune::YamlMap& planner,
                                     const std::string& base_dir) {
  engine::ClosedLoopOptions loop =
      engine::ClosedLoopOptions::FromYaml(planner, base_dir, {"waypoint"});
  const quadtune::YamlMap w = planner.Map("waypoint", true);
  w.RejectUnknownKeys({"check_dt", "limit_tolerance", "min_piece_time"});
  WaypointOptions o;
  o.check_dt = w.Number("check_dt", o.check_dt);
  o.limit_tolerance = w.Number("limit_tolerance", o.limit_tolerance);
  o.min_piece_time = w.Number("min_piece_time", o.min_piece_time);
  auto backend = std::make_shared<const WaypointBackend>(o, planner.file());
  return engine::Planner{engine::BackendPlanner{"waypoint", std::move(loop), std::move(backend)}};
}

void RegisterWaypointPlanner() {
  engine::RegisterPlanner("waypoint", BuildWaypointPlanner, engine::BackendPlanner::Schema());
}

}  // namespace own_planner
