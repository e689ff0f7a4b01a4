#include "quadtune/physics/ray_caster.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "physics_test_util.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/physics/world.hpp"

namespace quadtune::physics {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::Vector3d RandomUnit(Rng& rng) {
  Eigen::Vector3d d(StandardNormal(rng), StandardNormal(rng), StandardNormal(rng));
  return d.normalized();
}

TEST(RayCaster, CylinderSideMatchesClosedForm) {
  CylinderObstacle c;
  c.center_W = {5.0, 1.0};
  c.radius = 0.5;
  c.z_min = 0.0;
  c.z_max = 10.0;
  Rng rng(7);
  for (int i = 0; i < 1000; ++i) {
    // Horizontal rays from the origin at height 2 towards the cylinder.
    const double angle = Uniform(rng, -0.09, 0.09) + std::atan2(1.0, 5.0);
    const Eigen::Vector3d o(0, 0, 2);
    const Eigen::Vector3d d(std::cos(angle), std::sin(angle), 0.0);
    const Eigen::Vector2d to_c = c.center_W;
    const double along = to_c.dot(d.head<2>());
    const double miss2 = to_c.squaredNorm() - along * along;
    const double expected = miss2 < c.radius * c.radius ? along - std::sqrt(c.radius * c.radius - miss2) : kInf;
    const double t = IntersectRay(c, o, d, 100.0);
    if (std::isinf(expected)) {
      EXPECT_TRUE(std::isinf(t));
    } else {
      EXPECT_NEAR(t, expected, 1e-9);
    }
  }
}

TEST(RayCaster, CylinderCapsAndInsideOrigin) {
  CylinderObstacle c;
  c.center_W = {0.0, 0.0};
  c.radius = 1.0;
  c.z_min = 0.0;
  c.z_max = 2.0;
  EXPECT_NEAR(IntersectRay(c, {0.2, 0.1, 5.0}, {0, 0, -1}, 10.0), 3.0, 1e-12);  // top cap
  EXPECT_NEAR(IntersectRay(c, {0.2, 0.1, -1.0}, {0, 0, 1}, 10.0), 1.0, 1e-12);  // bottom cap
  EXPECT_EQ(IntersectRay(c, {0.0, 0.0, 1.0}, {1, 0, 0}, 10.0), 0.0);            // inside
  EXPECT_TRUE(std::isinf(IntersectRay(c, {0.0, 0.0, 3.0}, {1, 0, 0}, 10.0)));   // above
  EXPECT_TRUE(std::isinf(IntersectRay(c, {-5.0, 0.0, 1.0}, {1, 0, 0}, 3.0)));   // beyond t_max
  // Oblique ray entering through the top rim region.
  const Eigen::Vector3d d = Eigen::Vector3d(1, 0, -1).normalized();
  EXPECT_NEAR(IntersectRay(c, {-2.0, 0.0, 3.5}, d, 10.0), std::sqrt(2.0) * 1.5, 1e-12);
}

TEST(RayCaster, TorusHitsLieOnTheSurfaceAndMatchSphereTracing) {
  RingObstacle r;
  r.center_W = {3.0, -1.0, 2.0};
  r.yaw = 0.4;
  r.radius = 1.0;
  r.thickness = 0.12;
  Rng rng(11);
  int hits = 0;
  for (int i = 0; i < 3000; ++i) {
    const Eigen::Vector3d o = r.center_W + Eigen::Vector3d(Uniform(rng, -3, 3), Uniform(rng, -3, 3),
                                                           Uniform(rng, -3, 3));
    if (SignedDistance(r, o) < 0.0) continue;
    // Aim near the rim so that many rays hit.
    const double phi = Uniform(rng, 0, 2 * std::numbers::pi);
    const Eigen::Vector3d axis = r.Axis_W();
    const Eigen::Vector3d u(-axis.y(), axis.x(), 0.0);
    const Eigen::Vector3d rim = r.center_W + r.radius * (std::cos(phi) * u + std::sin(phi) * Eigen::Vector3d::UnitZ());
    const Eigen::Vector3d d = (rim + 0.1 * RandomUnit(rng) - o).normalized();
    const double t = IntersectRay(r, o, d, 20.0);
    // Reference: sphere tracing on the exact signed distance (never overshoots).
    double s = 0.0;
    double ref = kInf;
    for (int k = 0; k < 100000 && s < 20.0; ++k) {
      const double dist = SignedDistance(r, o + s * d);
      if (dist < 1e-7) {
        ref = s;
        break;
      }
      s += std::max(dist, 1e-5);
    }
    if (std::isinf(t)) {
      EXPECT_TRUE(std::isinf(ref)) << "missed a hit at " << ref;
      continue;
    }
    ++hits;
    EXPECT_NEAR(std::abs(SignedDistance(r, o + t * d)), 0.0, 1e-7);
    EXPECT_NEAR(t, ref, 1e-4);
  }
  EXPECT_GT(hits, 1000);
}

TEST(RayCaster, ThroughTheHoleMisses) {
  RingObstacle r;
  r.center_W = {5.0, 0.0, 2.0};
  r.radius = 1.0;
  r.thickness = 0.1;
  EXPECT_TRUE(std::isinf(IntersectRay(r, {0, 0, 2}, {1, 0, 0}, 20.0)));
  // Aimed at the rim's centre line from along the axis: hits the near face of the rim.
  const double t = IntersectRay(r, {0, 0, 3.0}, {1, 0, 0}, 20.0);
  EXPECT_NEAR(t, 5.0 - 0.05, 1e-9);
}

TEST(RayCaster, GridAgreesWithBruteForce) {
  const ObstacleSet set = testing::RandomForest(3, 150, 50, 30.0);
  const RayCaster caster(set);
  Rng rng(5);
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d o(Uniform(rng, -2, 32), Uniform(rng, -2, 32), Uniform(rng, 0.2, 3.5));
    const Eigen::Vector3d d = RandomUnit(rng);
    const double range = Uniform(rng, 1.0, 12.0);
    double best = IntersectGround(o, d, range);
    for (const auto& c : set.cylinders) best = std::min(best, IntersectRay(c, o, d, range));
    for (const auto& r : set.rings) best = std::min(best, IntersectRay(r, o, d, range));
    const RayHit hit = caster.Cast(o, d, range);
    if (std::isinf(best)) {
      EXPECT_FALSE(hit.hit());
    } else {
      ASSERT_TRUE(hit.hit());
      EXPECT_NEAR(hit.distance, best, 1e-9);  // torus roots depend on the bracket by < 1e-10
    }
  }
}

TEST(RayCaster, ReportsWhichObstacleWasHit) {
  ObstacleSet set;
  set.ground = true;
  CylinderObstacle c;
  c.center_W = {4.0, 0.0};
  c.radius = 0.5;
  set.cylinders.push_back(c);
  const RayCaster caster(set);
  const RayHit a = caster.Cast({0, 0, 1}, {1, 0, 0}, 10.0);
  EXPECT_EQ(a.obstacle, (ObstacleId{ObstacleKind::kCylinder, 0}));
  EXPECT_NEAR(a.distance, 3.5, 1e-12);
  const RayHit g = caster.Cast({0, 0, 1}, {0, 0, -1}, 10.0);
  EXPECT_EQ(g.obstacle.kind, ObstacleKind::kGround);
  EXPECT_NEAR(g.distance, 1.0, 1e-12);
  EXPECT_FALSE(caster.Cast({0, 0, 1}, {0, 0, 1}, 10.0).hit());
  EXPECT_FALSE(RayCaster().Cast({0, 0, 1}, {1, 0, 0}, 10.0).hit());
}

// The analytic caster against Bullet's rayTest on the same world. Cylinders agree to Bullet's
// single precision; rings to the capsule approximation (WorldOptions::ring_max_error).
TEST(RayCaster, AgreesWithBulletRayTest) {
  const ObstacleSet set = testing::RandomForest(9, 100, 40, 20.0);
  const DroneDescription drone;
  WorldOptions options;
  World world(set, drone, options, DroneState::Hover(drone, {-50, -50, 2}));
  const RayCaster& caster = world.ray_caster();
  Rng rng(13);
  int compared = 0, disagree = 0, cylinder_hits = 0, ring_hits = 0, cylinder_off = 0;
  double worst_cylinder = 0.0;
  for (int i = 0; i < 4000; ++i) {
    const Eigen::Vector3d o(Uniform(rng, 0, 20), Uniform(rng, 0, 20), Uniform(rng, 0.3, 3.0));
    if (set.Distance(o) < 0.3) continue;  // Bullet's GJK ray cast misses hits very close to the origin
    const Eigen::Vector3d d = RandomUnit(rng);
    const double range = 6.0;
    const RayHit hit = caster.Cast(o, d, range);
    const auto bullet = world.BulletRayDistance(o, o + range * d);
    ++compared;
    if (hit.hit() != bullet.has_value()) {
      ++disagree;  // grazing rays: the capsule ring and Bullet's margins differ by millimetres
      continue;
    }
    if (!hit.hit()) continue;
    // Bullet's hit point must lie on the surface the analytic caster found.
    const Eigen::Vector3d p_bullet = o + *bullet * d;
    double surface = 0.0;
    double tolerance = 2e-3;
    switch (hit.obstacle.kind) {
      case ObstacleKind::kGround:
        surface = p_bullet.z();
        break;
      case ObstacleKind::kCylinder:
        ++cylinder_hits;
        surface = SignedDistance(set.cylinders[static_cast<std::size_t>(hit.obstacle.index)], p_bullet);
        if (std::abs(surface) > 1e-3) ++cylinder_off;
        worst_cylinder = std::max(worst_cylinder, std::abs(surface));
        break;
      case ObstacleKind::kRing:
        ++ring_hits;
        surface = SignedDistance(set.rings[static_cast<std::size_t>(hit.obstacle.index)], p_bullet);
        tolerance += options.ring_max_error;
        break;
    }
    if (std::abs(surface) > tolerance) ++disagree;
  }
  std::printf("compared %d rays: %d cylinder hits, %d ring hits, %d disagreements, %d Bullet cylinder hit points > 1 mm off the exact surface (worst %.4f m)\n",
              compared, cylinder_hits, ring_hits, disagree, cylinder_off, worst_cylinder);
  EXPECT_GT(cylinder_hits, 200);
  EXPECT_GT(ring_hits, 50);
  EXPECT_LE(disagree, compared / 50);  // at most 2 % (grazing rays)
  EXPECT_LE(cylinder_off, cylinder_hits / 20);  // ≥ 95 % within 1 mm (Bullet: float, GJK tolerance)
}

}  // namespace
}  // namespace quadtune::physics
