#include "quadtune/layout/footprint.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace quadtune::layout {
namespace {

using physics::CylinderObstacle;
using physics::RingObstacle;

TEST(Footprint, CylinderIsItsDisc) {
  CylinderObstacle c;
  c.center_W = {1.0, -2.0};
  c.radius = 0.4;
  const Footprint f = FootprintOf(c);
  EXPECT_EQ(f.a_W, c.center_W);
  EXPECT_EQ(f.b_W, c.center_W);
  EXPECT_DOUBLE_EQ(f.radius, 0.4);
  EXPECT_DOUBLE_EQ(f.Reach(), 0.4);
  EXPECT_NEAR(FootprintGap(f, Eigen::Vector2d(2.0, -2.0)), 0.6, 1e-12);
}

TEST(Footprint, RingFacingXCoversASegmentAlongY) {
  RingObstacle r;
  r.center_W = {3.0, 1.0, 1.5};
  r.yaw = 0.0;  // axis along +x: the rim spans y
  r.radius = 1.0;
  r.thickness = 0.2;
  const Footprint f = FootprintOf(r);
  EXPECT_NEAR(f.HalfExtent().x(), 0.1, 1e-12);
  EXPECT_NEAR(f.HalfExtent().y(), 1.1, 1e-12);
  EXPECT_NEAR(f.Reach(), 1.1, 1e-12);
  EXPECT_TRUE(f.Center().isApprox(Eigen::Vector2d(3.0, 1.0)));
}

// The capsule must be exactly the torus's projection: every surface point projects inside it,
// and the capsule's extreme points are reached.
TEST(Footprint, RingFootprintIsTheTorusProjection) {
  RingObstacle r;
  r.center_W = {-1.0, 2.0, 1.4};
  r.yaw = 0.7;
  r.radius = 0.9;
  r.thickness = 0.3;
  const Footprint f = FootprintOf(r);
  const Eigen::Vector3d axis = r.Axis_W();
  const Eigen::Vector3d across(-std::sin(r.yaw), std::cos(r.yaw), 0.0);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  double farthest_across = 0.0;
  double farthest_along = 0.0;
  for (int i = 0; i < 90; ++i) {
    const double th = 2.0 * std::numbers::pi * i / 90;
    for (int j = 0; j < 24; ++j) {
      const double ph = 2.0 * std::numbers::pi * j / 24;
      const Eigen::Vector3d rim_dir = std::cos(th) * across + std::sin(th) * up;
      const Eigen::Vector3d p = r.center_W +
                                (r.radius + 0.5 * r.thickness * std::cos(ph)) * rim_dir +
                                0.5 * r.thickness * std::sin(ph) * axis;
      // On the torus surface by construction.
      ASSERT_NEAR(physics::SignedDistance(r, p), 0.0, 1e-9);
      EXPECT_LE(FootprintGap(f, Eigen::Vector2d(p.head<2>())), 1e-9);
      const Eigen::Vector3d d = p - r.center_W;
      farthest_across = std::max(farthest_across, std::abs(d.dot(across)));
      farthest_along = std::max(farthest_along, std::abs(d.dot(axis)));
    }
  }
  EXPECT_NEAR(farthest_across, r.radius + 0.5 * r.thickness, 1e-9);
  EXPECT_NEAR(farthest_along, 0.5 * r.thickness, 1e-3);
}

TEST(Footprint, SegmentDistanceCases) {
  const Eigen::Vector2d o(0, 0), x1(1, 0), y1(0, 1);
  // Crossing.
  EXPECT_DOUBLE_EQ(SegmentDistance({-1, 0}, {1, 0}, {0, -1}, {0, 1}), 0.0);
  // Parallel, 2 apart.
  EXPECT_DOUBLE_EQ(SegmentDistance({0, 0}, {1, 0}, {0, 2}, {1, 2}), 2.0);
  // Collinear, disjoint.
  EXPECT_DOUBLE_EQ(SegmentDistance({0, 0}, {1, 0}, {3, 0}, {5, 0}), 2.0);
  // Collinear, overlapping.
  EXPECT_DOUBLE_EQ(SegmentDistance({0, 0}, {2, 0}, {1, 0}, {5, 0}), 0.0);
  // T-junction touching.
  EXPECT_DOUBLE_EQ(SegmentDistance({0, 0}, {2, 0}, {1, 0}, {1, 3}), 0.0);
  // End point to interior.
  EXPECT_DOUBLE_EQ(SegmentDistance({0, 0}, {2, 0}, {1, 0.5}, {1, 3}), 0.5);
  // Degenerate segments (points).
  EXPECT_DOUBLE_EQ(SegmentDistance(o, o, x1, x1), 1.0);
  EXPECT_NEAR(SegmentDistance(x1, x1, o, y1), 1.0, 1e-15);
}

TEST(Footprint, GapBetweenRingAndCylinder) {
  RingObstacle r;  // yaw 0: rim from (0,-1) to (0,1), thickened by 0.05
  r.center_W = {0.0, 0.0, 1.5};
  r.radius = 1.0;
  r.thickness = 0.1;
  CylinderObstacle c;
  c.radius = 0.3;
  c.center_W = {0.0, 2.0};  // beyond the rim's end
  EXPECT_NEAR(FootprintGap(FootprintOf(r), FootprintOf(c)), 2.0 - 1.0 - 0.05 - 0.3, 1e-12);
  c.center_W = {1.0, 0.5};  // beside the rim
  EXPECT_NEAR(FootprintGap(FootprintOf(r), FootprintOf(c)), 1.0 - 0.05 - 0.3, 1e-12);
  c.center_W = {0.2, 0.5};  // overlapping
  EXPECT_LT(FootprintGap(FootprintOf(r), FootprintOf(c)), 0.0);
}

}  // namespace
}  // namespace quadtune::layout
