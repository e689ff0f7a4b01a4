#pragma once
// Shared helpers for the physics tests and benchmarks: seeded random obstacle layouts.

#include <cmath>
#include <cstdint>
#include <numbers>

#include "quadtune/common/random.hpp"
#include "quadtune/physics/obstacles.hpp"

namespace quadtune::physics::testing {

// A forest in [0, size]² like EGO-Planner's generator: pillars of radius 0.125–0.525 m up to
// 3 m, and vertical rings of radius 0.7–1.2 m with random yaw.
inline ObstacleSet RandomForest(std::uint64_t seed, int cylinders, int rings, double size = 40.0) {
  Rng rng(seed);
  ObstacleSet set;
  for (int i = 0; i < cylinders; ++i) {
    CylinderObstacle c;
    c.center_W = {Uniform(rng, 0.0, size), Uniform(rng, 0.0, size)};
    c.radius = Uniform(rng, 0.125, 0.525);
    c.z_min = 0.0;
    c.z_max = Uniform(rng, 2.0, 3.0);
    set.cylinders.push_back(c);
  }
  for (int i = 0; i < rings; ++i) {
    RingObstacle r;
    r.radius = Uniform(rng, 0.7, 1.2);
    r.thickness = Uniform(rng, 0.05, 0.15);
    r.center_W = {Uniform(rng, 0.0, size), Uniform(rng, 0.0, size),
                  Uniform(rng, r.radius + 0.2, r.radius + 1.0)};
    r.yaw = Uniform(rng, -std::numbers::pi, std::numbers::pi);
    set.rings.push_back(r);
  }
  return set;
}

}  // namespace quadtune::physics::testing
