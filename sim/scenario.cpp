#include "quadtune/sim/scenario.hpp"

#include <utility>

#include "quadtune/common/error.hpp"

namespace quadtune::sim {

Scenario Scenario::OverLayout(const layout::Layout& layout, MissionKind mission,
                              const physics::DroneDescription& drone, physics::WorldOptions world,
                              std::uint64_t seed,
                              std::shared_ptr<const physics::ObstacleGeometry> geometry) {
  world.seed = seed;
  world.Validate();
  Scenario s;
  s.drone = drone;
  s.obstacles =
      geometry ? std::move(geometry) : physics::ObstacleGeometry::Make(layout.obstacles, world);
  s.mission = mission == MissionKind::kGoAndReturn
                  ? Mission::GoAndReturn(layout.start_W(), layout.goal_W())
                  : Mission::GoTo(layout.start_W(), layout.goal_W());
  s.world = std::move(world);
  return s;
}

physics::DroneState StartState(const Scenario& scenario) {
  return physics::DroneState::Hover(scenario.drone, scenario.mission.start_W,
                                    scenario.mission.start_yaw, scenario.world.gravity);
}

physics::World& MakeWorld(const Scenario& scenario, std::shared_ptr<physics::World>& world) {
  QT_DEMAND(scenario.obstacles != nullptr, "MakeWorld: the scenario has no obstacle geometry");
  scenario.world.Validate();
  const physics::DroneState start = StartState(scenario);
  if (world) {
    world->Reset(scenario.obstacles, scenario.drone, scenario.world, start);
  } else {
    world =
        std::make_shared<physics::World>(scenario.obstacles, scenario.drone, scenario.world, start);
  }
  return *world;
}

}  // namespace quadtune::sim
