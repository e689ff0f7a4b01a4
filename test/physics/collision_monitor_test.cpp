#include "quadtune/physics/collision_monitor.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace quadtune::physics {
namespace {

const ObstacleId kCyl0{ObstacleKind::kCylinder, 0};
const ObstacleId kRing1{ObstacleKind::kRing, 1};
const ObstacleId kGround{ObstacleKind::kGround, 0};

TEST(CollisionMonitor, ContiguousContactIsOneEpisode) {
  CollisionMonitor m(0.05);
  const std::vector<ObstacleId> touching{kCyl0};
  for (int i = 0; i < 100; ++i) m.Update(1.0 + i * 0.001, touching, 2.0);
  for (int i = 100; i < 200; ++i) m.Update(1.0 + i * 0.001, {}, 0.0);
  ASSERT_EQ(m.Count(), 1u);
  EXPECT_EQ(m.episodes()[0].obstacle, kCyl0);
  EXPECT_DOUBLE_EQ(m.episodes()[0].start_time, 1.0);
  EXPECT_NEAR(m.episodes()[0].last_time, 1.099, 1e-12);
  EXPECT_DOUBLE_EQ(m.episodes()[0].impact_speed, 2.0);
  EXPECT_EQ(m.FirstContactTime(), 1.0);
  EXPECT_FALSE(m.InContact(1.2));
}

TEST(CollisionMonitor, BriefGapContinuesLongGapStartsNewEpisode) {
  CollisionMonitor m(0.05);
  const std::vector<ObstacleId> touching{kCyl0};
  m.Update(0.00, touching, 1.0);
  m.Update(0.03, touching, 1.0);  // gap 0.03 <= 0.05: same episode
  EXPECT_EQ(m.Count(), 1u);
  m.Update(0.20, touching, 1.0);  // gap 0.17 > 0.05: new episode
  EXPECT_EQ(m.Count(), 2u);
  EXPECT_EQ(m.CountFor(kCyl0), 2u);
}

TEST(CollisionMonitor, DuplicatesAndSimultaneousObstacles) {
  CollisionMonitor m(0.05);
  const std::vector<ObstacleId> touching{kRing1, kCyl0, kRing1, kGround};
  m.Update(0.5, touching, 3.0);
  m.Update(0.501, touching, 3.0);
  EXPECT_EQ(m.Count(), 3u);
  EXPECT_EQ(m.CountFor(kRing1), 1u);
  EXPECT_EQ(m.CountFor(ObstacleKind::kGround), 1u);
  EXPECT_EQ(m.CountObstacles(), 2u);
  EXPECT_TRUE(m.InContact(0.52));
  // Episodes that start together are ordered by obstacle id.
  EXPECT_EQ(m.episodes()[0].obstacle, kGround);
  EXPECT_EQ(m.episodes()[1].obstacle, kCyl0);
  m.Reset();
  EXPECT_EQ(m.Count(), 0u);
  EXPECT_FALSE(m.FirstContactTime().has_value());
}

TEST(CollisionMonitor, ObstacleIdNames) {
  EXPECT_EQ(kGround.ToString(), "ground");
  EXPECT_EQ(kCyl0.ToString(), "cylinders[0]");
  EXPECT_EQ(kRing1.ToString(), "rings[1]");
}

}  // namespace
}  // namespace quadtune::physics
