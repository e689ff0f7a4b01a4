#pragma once
/// \file
/// The waypoint planner as a quadtune planner type: `planner.type: waypoint` takes the closed
/// loop's keys of the ipopt planner (drone, layout, mission, ...) and an optional `waypoint:` map
/// of WaypointOptions, and builds an engine::BackendPlanner around a WaypointBackend.
///
/// Thread safety: RegisterWaypointPlanner may be called from any thread (the registry locks);
/// the planner it builds is immutable.

#include <string>

#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/api/planner.hpp"

namespace own_planner {

/// The plug-in of a `planner:` map of type waypoint (the registry's factory).
quadtune::engine::Planner BuildWaypointPlanner(const quadtune::YamlMap& planner,
                                               const std::string& base_dir);

/// Registers `planner.type: waypoint` (once per program, before experiments naming it load).
void RegisterWaypointPlanner();

}  // namespace own_planner
