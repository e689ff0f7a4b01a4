// A physics World built from a loaded layout: the layout is the world's obstacle description.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "quadtune/layout/layout.hpp"
#include "quadtune/physics/world.hpp"

namespace quadtune::layout {
namespace {

TEST(LayoutWorld, WorldBuiltFromLoadedLayoutHasItsObstacles) {
  const Layout layout = Layout::Load(std::string(QUADTUNE_SOURCE_DIR) +
                                     "/assets/layouts/forest_1p3_seed1.layout.yaml");
  const physics::DroneDescription drone;
  const physics::World world(layout.obstacles, drone, physics::WorldOptions{},
                             physics::DroneState::Hover(drone, layout.start_W()));
  EXPECT_EQ(world.obstacles(), layout.obstacles);

  // Bullet's geometry agrees with the layout's analytic obstacles: a horizontal ray towards a
  // pillar's axis hits its surface (up to the collision margin), and the start is free.
  ASSERT_FALSE(layout.obstacles.cylinders.empty());
  int checked = 0;
  for (std::size_t i = 0; i < std::min<std::size_t>(5, layout.obstacles.cylinders.size()); ++i) {
    const auto& c = layout.obstacles.cylinders[i];
    const Eigen::Vector3d target(c.center_W.x(), c.center_W.y(), 1.0);
    // Come from the side facing the region's centre line, from just outside the pillar.
    const Eigen::Vector3d from =
        target + Eigen::Vector3d(0.0, c.center_W.y() > 0 ? -1.0 : 1.0, 0.0) * (c.radius + 0.15);
    const double analytic = layout.obstacles.Distance(from);
    if (analytic < 0.149) continue;  // another obstacle is nearer (never within min_gap)
    const auto hit = world.BulletRayDistance(from, target);
    ASSERT_TRUE(hit.has_value()) << "cylinder " << i;
    EXPECT_NEAR(*hit, 0.15, 0.01) << "cylinder " << i;
    ++checked;
  }
  EXPECT_GE(checked, 3);
  EXPECT_GT(layout.obstacles.Distance(layout.start_W()), 1.0);
  EXPECT_EQ(world.collisions().Count(), 0u);
}

}  // namespace
}  // namespace quadtune::layout
