#include "quadtune/planning/esdf.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "../config_error_util.hpp"
#include "analytic_fields.hpp"
#include "mapping_scenes.hpp"
#include "quadtune/common/random.hpp"

namespace quadtune::planning {
namespace {

using quadtune::test::ThrowsWithMessage;

using Eigen::Vector3d;
using Eigen::Vector3i;

std::size_t Index(const Vector3i& i, const Vector3i& dims) {
  return static_cast<std::size_t>(i.x() + dims.x() * (i.y() + dims.y() * i.z()));
}

/// Brute force: signed distance between cell centres as documented in esdf.hpp.
double BruteForce(const std::vector<std::uint8_t>& occ, const Vector3i& dims, const Vector3i& c,
                  double res) {
  const bool self = occ[Index(c, dims)] != 0;
  double best = std::numeric_limits<double>::infinity();
  for (int z = 0; z < dims.z(); ++z) {
    for (int y = 0; y < dims.y(); ++y) {
      for (int x = 0; x < dims.x(); ++x) {
        const Vector3i o(x, y, z);
        if ((occ[Index(o, dims)] != 0) == self) continue;
        best = std::min(best, (o - c).cast<double>().norm());
      }
    }
  }
  const double d = (best - 0.5) * res;
  return self ? -d : d;
}

TEST(Esdf, MatchesBruteForceOnRandomOccupancy) {
  const Vector3i dims(23, 17, 11);
  const double res = 0.1;
  EsdfOptions opt;
  opt.max_distance = 5.0;  // larger than any distance in the box: no truncation
  for (double density : {0.002, 0.05, 0.3, 0.9}) {
    Rng rng(DeriveSeed(5, {static_cast<std::uint64_t>(density * 1000)}));
    std::vector<std::uint8_t> occ(static_cast<std::size_t>(dims.prod()));
    for (auto& o : occ) o = Uniform01(rng) < density ? 1 : 0;
    const Esdf esdf = Esdf::FromOccupancy(Vector3d(-1.0, 0.5, 0.0), res, dims, occ, opt);
    double worst = 0.0;
    for (int z = 0; z < dims.z(); ++z) {
      for (int y = 0; y < dims.y(); ++y) {
        for (int x = 0; x < dims.x(); ++x) {
          const Vector3i c(x, y, z);
          const double expected = BruteForce(occ, dims, c, res);
          worst = std::max(worst, std::abs(esdf.CellDistance(c) - expected));
          // Evaluate at a cell centre returns the stored value.
          ASSERT_NEAR(esdf.Evaluate(esdf.CellCenter(c), nullptr), esdf.CellDistance(c), 1e-12);
        }
      }
    }
    EXPECT_LE(worst, esdf.quantum()) << "density " << density;
  }
}

/// Brute force of the stored (quantised) value, computed the way esdf.hpp documents it: nearest
/// opposite cell centre, minus half a cell, clamped at max_distance, rounded to the quantum.
double BruteForceStored(const std::vector<std::uint8_t>& occ, const Vector3i& dims,
                        const Vector3i& c, double res, double max_distance) {
  const bool self = occ[Index(c, dims)] != 0;
  long best_sq = -1;
  for (int z = 0; z < dims.z(); ++z) {
    for (int y = 0; y < dims.y(); ++y) {
      for (int x = 0; x < dims.x(); ++x) {
        const Vector3i o(x, y, z);
        if ((occ[Index(o, dims)] != 0) == self) continue;
        const long sq = (o - c).squaredNorm();
        if (best_sq < 0 || sq < best_sq) best_sq = sq;
      }
    }
  }
  const double d = best_sq < 0 ? max_distance
                               : std::min((std::sqrt(static_cast<double>(best_sq)) - 0.5) * res,
                                          max_distance);
  const double quantum = max_distance / 16000.0;
  const double q = static_cast<double>(std::lround(d * (1.0 / quantum)));
  return (self ? -q : q) * quantum;
}

// Truncation distances of up to ~88 cells take the windowed 16-bit transform, longer ones the
// lower envelope; both must store exactly the brute-force values, truncated or not. The inside
// transform first tries a short truncation: at density 0.97 every deep cell finds a free centre
// within it, at 0.999 (a handful of free cells) most do not and the full one runs.
TEST(Esdf, BothTransformsStoreTheExactTruncatedDistance) {
  const Vector3i dims(29, 17, 13);
  const double res = 0.1;
  for (double max_distance : {0.35, 1.0, 2.0, 9.5}) {
    EsdfOptions opt;
    opt.max_distance = max_distance;
    for (double density : {0.003, 0.05, 0.6, 0.97, 0.999}) {
      Rng rng(DeriveSeed(11, {static_cast<std::uint64_t>(density * 1000),
                              static_cast<std::uint64_t>(max_distance * 100)}));
      std::vector<std::uint8_t> occ(static_cast<std::size_t>(dims.prod()));
      for (auto& o : occ) o = Uniform01(rng) < density ? 1 : 0;
      const Esdf esdf = Esdf::FromOccupancy(Vector3d(0.2, -0.4, 0.0), res, dims, occ, opt);
      int mismatches = 0;
      for (int z = 0; z < dims.z(); ++z) {
        for (int y = 0; y < dims.y(); ++y) {
          for (int x = 0; x < dims.x(); ++x) {
            const Vector3i c(x, y, z);
            const double expected = BruteForceStored(occ, dims, c, res, max_distance);
            if (esdf.CellDistance(c) != expected && ++mismatches <= 3) {
              ADD_FAILURE() << "max_distance " << max_distance << " density " << density
                            << " cell " << c.transpose() << ": " << esdf.CellDistance(c)
                            << " != " << expected;
            }
          }
        }
      }
      EXPECT_EQ(mismatches, 0) << "max_distance " << max_distance << " density " << density;
    }
  }
}

TEST(Esdf, TruncatesAtMaxDistance) {
  const Vector3i dims(40, 5, 5);
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(dims.prod()), 0);
  occ[Index(Vector3i(0, 2, 2), dims)] = 1;
  EsdfOptions opt;
  opt.max_distance = 1.0;
  const Esdf esdf = Esdf::FromOccupancy(Vector3d::Zero(), 0.1, dims, occ, opt);
  EXPECT_NEAR(esdf.CellDistance(Vector3i(5, 2, 2)), 0.45, 1e-4);
  EXPECT_NEAR(esdf.CellDistance(Vector3i(10, 2, 2)), 0.95, 1e-4);
  EXPECT_NEAR(esdf.CellDistance(Vector3i(30, 2, 2)), 1.0, 1e-12);
  EXPECT_NEAR(esdf.CellDistance(Vector3i(0, 2, 2)), -0.05, 1e-4);
  // An empty box is max_distance everywhere; outside the box too, with zero gradient.
  const Esdf empty = Esdf::FromOccupancy(Vector3d::Zero(), 0.1, dims,
                                         std::vector<std::uint8_t>(occ.size(), 0), opt);
  Vector3d grad(1, 1, 1);
  EXPECT_DOUBLE_EQ(empty.Evaluate(Vector3d(1, 0.2, 0.2), &grad), 1.0);
  EXPECT_EQ(grad, Vector3d::Zero());
  grad.setOnes();
  EXPECT_DOUBLE_EQ(esdf.Evaluate(Vector3d(-0.5, 0.2, 0.2), &grad), 1.0);
  EXPECT_EQ(grad, Vector3d::Zero());
  EXPECT_DOUBLE_EQ(Esdf().Evaluate(Vector3d::Zero(), nullptr), EsdfOptions{}.max_distance);
}

TEST(Esdf, GradientMatchesFiniteDifferences) {
  const Vector3i dims(30, 25, 20);
  Rng rng(17);
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(dims.prod()));
  for (auto& o : occ) o = Uniform01(rng) < 0.02 ? 1 : 0;
  const double res = 0.1;
  const Vector3d origin(0.3, -1.2, 0.0);
  const Esdf esdf = Esdf::FromOccupancy(origin, res, dims, occ);
  const double h = 1e-6;
  int checked = 0;
  for (int i = 0; i < 3000; ++i) {
    const Vector3d p = origin + Vector3d(Uniform(rng, 0, 3.0), Uniform(rng, 0, 2.5),
                                         Uniform(rng, 0, 2.0));
    // Skip points within h of a cell-centre plane, where the interpolant's gradient jumps.
    const Vector3d u = (p - origin) / res - Vector3d::Constant(0.5);
    bool near_plane = false;
    for (int k = 0; k < 3; ++k) near_plane |= std::abs(u[k] - std::round(u[k])) < 1e-4;
    if (near_plane) continue;
    Vector3d grad;
    esdf.Evaluate(p, &grad);
    for (int k = 0; k < 3; ++k) {
      Vector3d e = Vector3d::Zero();
      e[k] = h;
      const double fd = (esdf.Evaluate(p + e, nullptr) - esdf.Evaluate(p - e, nullptr)) / (2 * h);
      ASSERT_NEAR(grad[k], fd, 1e-6 * std::max(1.0, std::abs(fd))) << "axis " << k << " at " << p.transpose();
    }
    ++checked;
  }
  EXPECT_GT(checked, 2900);
}

TEST(Esdf, ApproximatesObstacleSetDistanceFromSensedSurfaces) {
  const physics::ObstacleSet scene = test::Forest(1.3, 0.5, 7.0, -2.5, 2.5, 21);
  LocalMapOptions mo;
  mo.inflation = 0.1;
  mo.size = Vector3d(16, 12, 4);
  LocalMap map(mo, Vector3d(4, 0, 1.5));
  const std::vector<Vector3d> surface = test::SurfaceSamples(scene, 0.03);
  map.Insert(Vector3d(4, 0, 1.5), surface);
  const Eigen::AlignedBox3d box(Vector3d(-1.0, -3.0, 0.0), Vector3d(9.0, 3.0, 3.0));
  EsdfOptions options;
  options.max_distance = 2.0;  // above every checked distance
  const Esdf esdf = Esdf::Build(map, box, options);
  EXPECT_LE(esdf.box().min().z(), -0.1 + 1e-9);  // one ground layer added
  Rng rng(23);
  int checked = 0;
  double worst = 0.0;
  for (int i = 0; i < 20000; ++i) {
    const Vector3d p(Uniform(rng, -0.5, 8.5), Uniform(rng, -2.5, 2.5), Uniform(rng, 0.05, 2.5));
    const double truth = scene.Distance(p);
    if (truth <= 0.0 || truth > 1.5) continue;  // the map knows surfaces, not interiors
    worst = std::max(worst, std::abs(esdf.Evaluate(p, nullptr) - truth));
    ++checked;
  }
  EXPECT_GT(checked, 10000);
  EXPECT_LT(worst, 0.15);  // 1.5 voxels
}

TEST(Esdf, SignedDistanceOfSolidOccupancyMatchesObstacleSet) {
  physics::ObstacleSet scene;
  scene.ground = false;
  // Tall enough that the cylinders' end faces are far from the sampled heights.
  scene.cylinders.push_back({Eigen::Vector2d(1.02, 0.97), 0.5, -5.0, 5.0});
  scene.cylinders.push_back({Eigen::Vector2d(2.41, 1.6), 0.3, -5.0, 5.0});
  const Vector3i dims(40, 30, 10);
  const double res = 0.1;
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(dims.prod()));
  for (int z = 0; z < dims.z(); ++z) {
    for (int y = 0; y < dims.y(); ++y) {
      for (int x = 0; x < dims.x(); ++x) {
        const Vector3d c = (Vector3i(x, y, z).cast<double>().array() + 0.5).matrix() * res;
        occ[Index(Vector3i(x, y, z), dims)] = scene.Distance(c) < 0.0 ? 1 : 0;
      }
    }
  }
  EsdfOptions options;
  options.max_distance = 3.0;  // above every distance in the box
  const Esdf esdf = Esdf::FromOccupancy(Vector3d::Zero(), res, dims, occ, options);
  Rng rng(29);
  double worst = 0.0;
  for (int i = 0; i < 5000; ++i) {
    const Vector3d p(Uniform(rng, 0.1, 3.9), Uniform(rng, 0.1, 2.9), Uniform(rng, 0.3, 0.7));
    worst = std::max(worst, std::abs(esdf.Evaluate(p, nullptr) - scene.Distance(p)));
  }
  EXPECT_LT(worst, 0.1);  // one voxel, inside the cylinders too
  // Inside, the gradient points out of the obstacle.
  Vector3d grad;
  const double d = esdf.Evaluate(Vector3d(1.32, 0.97, 0.5), &grad);
  EXPECT_LT(d, 0.0);
  EXPECT_GT(grad.x(), 0.5);
}

TEST(Esdf, GroundLayerGivesHeightAboveGround) {
  LocalMapOptions mo;
  LocalMap map(mo, Vector3d(0, 0, 1.5));
  EsdfOptions options;
  options.max_distance = 2.0;
  const Esdf esdf =
      Esdf::Build(map, Eigen::AlignedBox3d(Vector3d(-2, -2, 0), Vector3d(2, 2, 3)), options);
  EXPECT_NEAR(esdf.Evaluate(Vector3d(0.3, 0.2, 0.55), nullptr), 0.55, 1e-3);
  Vector3d grad;
  esdf.Evaluate(Vector3d(0.3, 0.2, 1.23), &grad);
  EXPECT_NEAR(grad.z(), 1.0, 1e-3);
  EXPECT_NEAR(esdf.Evaluate(Vector3d(0.3, 0.2, 2.5), nullptr), 2.0, 1e-9);  // truncated
}

TEST(Esdf, IsACopyableValueSafeForConcurrentEvaluate) {
  const physics::ObstacleSet scene = test::Forest(1.3, 0.5, 7.0, -2.5, 2.5, 31);
  LocalMap map(LocalMapOptions{}, Vector3d(3, 0, 1.5));
  map.Insert(Vector3d(3, 0, 1.5), test::SurfaceSamples(scene, 0.05));
  Esdf original = Esdf::Build(map, Eigen::AlignedBox3d(Vector3d(0, -3, 0), Vector3d(7, 3, 3)));
  const Esdf copy = original;  // a snapshot
  EXPECT_EQ(copy.MemoryBytes(), original.MemoryBytes());
  EXPECT_LT(copy.MemoryBytes(), sizeof(Esdf) + 2 * 71 * 61 * 32 + 64);
  Rng rng(37);
  std::vector<Vector3d> pts(4000);
  for (auto& p : pts) p = Vector3d(Uniform(rng, -0.5, 7.5), Uniform(rng, -3.5, 3.5), Uniform(rng, 0, 3));
  std::vector<double> serial(pts.size());
  for (std::size_t i = 0; i < pts.size(); ++i) serial[i] = copy.Evaluate(pts[i], nullptr);
  original = Esdf();  // the copy does not depend on the original
  for (int threads : {1, 2, 4, 8}) {
    std::vector<std::vector<double>> out(static_cast<std::size_t>(threads),
                                         std::vector<double>(pts.size()));
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) {
      pool.emplace_back([&, t] {
        for (std::size_t i = 0; i < pts.size(); ++i) {
          Vector3d g;
          out[static_cast<std::size_t>(t)][i] = copy.Evaluate(pts[i], &g);
        }
      });
    }
    for (auto& th : pool) th.join();
    for (const auto& o : out) ASSERT_EQ(o, serial) << threads << " threads";
  }
  const DistanceField& field = copy;  // usable through the optimiser's interface
  EXPECT_DOUBLE_EQ(field.Evaluate(pts[0], nullptr), serial[0]);
}

TEST(Esdf, BuilderReuseGivesIdenticalFields) {
  const physics::ObstacleSet scene = test::Forest(1.3, 0.5, 7.0, -2.5, 2.5, 41);
  LocalMap map(LocalMapOptions{}, Vector3d(3, 0, 1.5));
  map.Insert(Vector3d(3, 0, 1.5), test::SurfaceSamples(scene, 0.05));
  EsdfBuilder builder;
  const Eigen::AlignedBox3d big(Vector3d(0, -3, 0), Vector3d(7, 3, 3));
  const Eigen::AlignedBox3d small(Vector3d(1, -1, 0.5), Vector3d(3, 1, 2));
  const Esdf a = builder.Build(map, big);
  (void)builder.Build(map, small);
  const Esdf b = builder.Build(map, big);
  const Esdf c = Esdf::Build(map, big);
  for (const Vector3d& p : {Vector3d(1, 0, 1), Vector3d(3.3, 1.1, 2.2), Vector3d(6.5, -2.9, 0.1)}) {
    EXPECT_EQ(a.Evaluate(p, nullptr), b.Evaluate(p, nullptr));
    EXPECT_EQ(a.Evaluate(p, nullptr), c.Evaluate(p, nullptr));
  }
}

TEST(EsdfOptions, ValidateRejectsEachBadValue) {
  EXPECT_NO_THROW(EsdfOptions{}.Validate());
  EsdfOptions o;
  o.max_distance = 0.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { o.Validate(); }, "max_distance",
                                                  {"allowed: a number in (0, 30]"}));
  o.max_distance = 40.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { o.Validate(); }, "max_distance",
                                                  {"allowed: a number in (0, 30]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { (void)EsdfOptions::FromYaml(YamlMap::FromString("max_dist: 1\n")); }, "max_dist",
      {"unknown key; allowed keys"}));
  EXPECT_DOUBLE_EQ(EsdfOptions::FromYaml(YamlMap::FromString("max_distance: 1.5\n")).max_distance,
                   1.5);
  LocalMap map(LocalMapOptions{});
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { (void)Esdf::Build(map, Eigen::AlignedBox3d()); },
      {"Esdf::Build", "finite and non-empty"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        (void)Esdf::FromOccupancy(Vector3d::Zero(), 0.1, Vector3i(2, 2, 2),
                                  std::vector<std::uint8_t>(7, 0));
      },
      {"7 cells", "dims need 8"}));
}

// Two voxelised pillars, 0.25 and 0.15 m in radius, in a 3 × 2.5 × 2 m box.
Esdf TwoPillars() {
  physics::CylinderObstacle c1;
  c1.center_W = Eigen::Vector2d(1.0, 0.0);
  c1.radius = 0.25;
  physics::CylinderObstacle c2;
  c2.center_W = Eigen::Vector2d(1.9, 0.5);
  c2.radius = 0.15;
  return testing::VoxelisedCylinders({c1, c2}, 0.0, 3.0, -1.0, 1.5, 0.0, 2.0);
}

TEST(Esdf, CurvatureIsExactDerivativeOfASmoothFieldCloseToTheSamples) {
  const Esdf esdf = TwoPillars();
  const Esdf& field = esdf;
  ASSERT_TRUE(field.ProvidesCurvature());
  const double h = 1e-6;
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0.5, 0.3, 1.0), Eigen::Vector3d(1.45, 0.27, 1.03),
        Eigen::Vector3d(1.0, 0.41, 0.95), Eigen::Vector3d(2.3, -0.2, 1.27)}) {
    Eigen::Vector3d grad;
    Eigen::Matrix3d hess;
    const double d = field.EvaluateWithHessian(p, &grad, &hess);
    EXPECT_NEAR(d, esdf.Evaluate(p, nullptr), 0.02) << p.transpose();
    Eigen::Vector3d fd_grad;
    Eigen::Matrix3d fd_hess;
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d e = h * Eigen::Vector3d::Unit(i);
      Eigen::Vector3d gp;
      Eigen::Vector3d gm;
      fd_grad(i) = (field.EvaluateWithHessian(p + e, &gp, nullptr) -
                    field.EvaluateWithHessian(p - e, &gm, nullptr)) /
                   (2 * h);
      fd_hess.col(i) = (gp - gm) / (2 * h);
    }
    EXPECT_LT((grad - fd_grad).norm(), 1e-7) << p.transpose();
    EXPECT_LT((hess - fd_hess).norm(), 1e-5 * (1.0 + hess.norm())) << p.transpose();
    EXPECT_EQ(hess, hess.transpose());
  }
}

// The collision cost skips samples through EvaluateWithHessianBelow: a skip must be a point
// whose smooth distance is at least the threshold, and an evaluation must give the same bits as
// EvaluateWithHessian. Points on a grid over the box (its border cells included, where the
// stencil is clamped) and just outside it, thresholds around the clearance.
TEST(Esdf, EvaluateBelowSkipsOnlyPointsAtOrAboveTheThresholdAndOtherwiseMatchesBitwise) {
  const Esdf esdf = TwoPillars();
  const DistanceField& field = esdf;
  int skipped = 0;
  int evaluated = 0;
  for (double threshold : {-0.1, 0.2, 0.5, 0.9, 2.0}) {
    for (double x = -0.07; x <= 3.1; x += 0.0731) {
      for (double y = -1.07; y <= 1.6; y += 0.0893) {
        for (double z = -0.05; z <= 2.1; z += 0.217) {
          const Eigen::Vector3d p(x, y, z);
          Eigen::Vector3d g_ref;
          Eigen::Matrix3d h_ref;
          const double ref = field.EvaluateWithHessian(p, &g_ref, &h_ref);
          double d = -1.0;
          Eigen::Vector3d g = Eigen::Vector3d::Constant(7.0);
          Eigen::Matrix3d h = Eigen::Matrix3d::Constant(7.0);
          if (!field.EvaluateWithHessianBelow(p, threshold, &d, &g, &h)) {
            ++skipped;
            EXPECT_GE(ref, threshold) << p.transpose();
            EXPECT_EQ(d, -1.0);  // nothing written
            continue;
          }
          ++evaluated;
          EXPECT_EQ(d, ref) << p.transpose();
          EXPECT_EQ(g, g_ref) << p.transpose();
          EXPECT_EQ(h, h_ref) << p.transpose();
          // The value-only form makes the same decision and the same value.
          double v = -1.0;
          EXPECT_TRUE(field.EvaluateWithHessianBelow(p, threshold, &v, nullptr, nullptr));
          EXPECT_EQ(v, field.EvaluateWithHessian(p, nullptr, nullptr)) << p.transpose();
        }
      }
    }
  }
  // Both outcomes occur, and a point next to an obstacle is never skipped at the clearance.
  EXPECT_GT(skipped, 1000);
  EXPECT_GT(evaluated, 1000);
  double d = 0.0;
  EXPECT_TRUE(field.EvaluateWithHessianBelow(Eigen::Vector3d(1.3, 0.0, 1.0), 0.5, &d, nullptr,
                                             nullptr));
  EXPECT_LT(d, 0.5);
  // Outside the box the field reads max_distance: skipped below it, evaluated above it.
  EXPECT_FALSE(field.EvaluateWithHessianBelow(Eigen::Vector3d(9, 9, 9), 0.5, &d, nullptr,
                                              nullptr));
  EXPECT_TRUE(field.EvaluateWithHessianBelow(Eigen::Vector3d(9, 9, 9), 2.0, &d, nullptr,
                                             nullptr));
  EXPECT_EQ(d, esdf.max_distance());
}

TEST(Esdf, CurvatureOutsideTheBoxIsFlat) {
  const Esdf esdf = testing::VoxelisedCylinders({}, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0);
  Eigen::Vector3d g;
  Eigen::Matrix3d h;
  EXPECT_EQ(esdf.EvaluateWithHessian(Eigen::Vector3d(5, 5, 5), &g, &h), esdf.max_distance());
  EXPECT_EQ(g, Eigen::Vector3d::Zero());
  EXPECT_EQ(h, Eigen::Matrix3d::Zero());
}

}  // namespace
}  // namespace quadtune::planning
