#pragma once
/// \file
/// What one flight flies through, as a value: the drone, the obstacles, the mission and the
/// world's settings (rates, wind, sensor and state noise) with the seed of its random streams.
/// `quadtune fly`, the engine's closed-loop planners and online adaptation all describe their
/// flights this way and make their physics::World with MakeWorld(), so that the same scenario
/// gives the same world, start state and flight wherever it is flown.
///
/// Thread safety: a Scenario is a value; its obstacle geometry is immutable and may be shared by
/// scenarios flown concurrently (in different Worlds). MakeWorld() touches only its arguments.

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/quadrotor.hpp"
#include "quadtune/physics/world.hpp"
#include "quadtune/sim/flight.hpp"

namespace quadtune::sim {

/// The mission a scenario flies over a layout (an experiment's `planner.mission`).
enum class MissionKind {
  kGoAndReturn,  ///< "go_and_return": to the layout's goal and back to its start (the paper's)
  kGoTo,         ///< "go_to": to the layout's goal only
};
/// The files' and the command line's spellings: "go_and_return", "go_to".
constexpr auto EnumNames(MissionKind) {
  return std::array{EnumName{MissionKind::kGoAndReturn, "go_and_return"},
                    EnumName{MissionKind::kGoTo, "go_to"}};
}

/// One flight's surroundings. Fly(world, scenario.mission, ...) flies it in MakeWorld's world.
struct Scenario {
  physics::DroneDescription drone;                             ///< the drone flown
  std::shared_ptr<const physics::ObstacleGeometry> obstacles;  ///< static obstacles, not null
  Mission mission;                                             ///< start, heading and waypoints
  /// Rates, wind, noise and collision response; `world.seed` seeds the world's random streams
  /// (and, through Fly, the depth sensor's). The obstacles' ring_max_error and obstacle_margin
  /// are those of `obstacles`.
  physics::WorldOptions world;

  /// The scenario over `layout`: its start and goal as `mission`, its obstacles (built with
  /// `world`'s ring_max_error and obstacle_margin unless a pre-built `geometry` of the same
  /// obstacles is given, e.g. one shared by every flight on that map), `world` with its seed
  /// replaced by `seed`. Throws ConfigError for invalid world options or obstacles.
  static Scenario OverLayout(const layout::Layout& layout, MissionKind mission,
                             const physics::DroneDescription& drone, physics::WorldOptions world,
                             std::uint64_t seed,
                             std::shared_ptr<const physics::ObstacleGeometry> geometry = nullptr);
};

/// The drone's state when `scenario` starts: hovering at the mission's start, heading
/// mission.start_yaw, under the world's gravity.
[[nodiscard]] physics::DroneState StartState(const Scenario& scenario);

/// Makes the world of `scenario`, at its start state: builds it into `world` when that is empty,
/// else Reset()s the world it holds (static objects are rebuilt only when the geometry differs;
/// the result is bit-identical to a fresh World, so a pool of worlds can be re-used across
/// flights). Returns *world. Throws ConfigError for invalid world options or drone, and
/// InvariantError when the scenario has no obstacle geometry.
physics::World& MakeWorld(const Scenario& scenario, std::shared_ptr<physics::World>& world);

}  // namespace quadtune::sim
