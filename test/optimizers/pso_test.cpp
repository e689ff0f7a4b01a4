#include "quadtune/optimizers/pso.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "../config_error_util.hpp"
#include "quadtune/optimizers/random_search.hpp"
#include "test_functions.hpp"

namespace quadtune::optimizers {
namespace {

using quadtune::test::ThrowsWithMessage;

using testing::BoxSpace;
using testing::Rosenbrock;
using testing::Sphere;

/// Synchronous rounds of the whole swarm; returns the true regret f(Best().x) (f* = 0).
template <class F>
double RunPso(const ParameterSpace& space, F f, int rounds, double noise_sd, PsoOptions o) {
  Pso pso(space, o);
  Rng noise(DeriveSeed(o.seed, {5}));
  for (int r = 0; r < rounds; ++r) {
    const auto c = pso.Ask(o.num_particles);
    std::vector<double> v;
    for (const auto& x : c) v.push_back(f(x.x) + noise_sd * StandardNormal(noise));
    pso.Tell(c, v);
  }
  return f(pso.Best()->x);
}

template <class F>
std::vector<double> OverSeeds(const ParameterSpace& space, F f, int rounds, double noise_sd, PsoOptions o) {
  std::vector<double> r;
  for (std::uint64_t seed = 0; seed < 10; ++seed) {
    o.seed = seed;
    r.push_back(RunPso(space, f, rounds, noise_sd, o));
  }
  std::sort(r.begin(), r.end());
  std::printf("regrets: median %.3g max %.3g\n", 0.5 * (r[4] + r[5]), r[9]);
  return r;
}

// Documented performance (10 seeds, 20 particles, defaults; measured median / max in comments).
TEST(PsoPerformance, SphereReachesRegretWithin2000Evaluations) {
  // Sphere 5-D on [-5, 5]^5, 100 rounds × 20 particles: median 3.6e-8, max 3.8e-7.
  const auto r = OverSeeds(BoxSpace(5, -5.0, 5.0), Sphere, 100, 0.0, {});
  EXPECT_LE(r[5], 1e-5);
  EXPECT_LE(r[9], 1e-4);
}

TEST(PsoPerformance, RosenbrockReachesRegretWithin3000Evaluations) {
  // Rosenbrock 2-D on [-2, 2]^2, 150 rounds × 20 particles: median 3.3e-7, max 2.0e-5.
  const auto r = OverSeeds(BoxSpace(2, -2.0, 2.0), Rosenbrock, 150, 0.0, {});
  EXPECT_LE(r[5], 1e-4);
  EXPECT_LE(r[9], 1e-3);
}

/// Uniform random search with the same budget and noise as RunPso; sorted true regrets over the
/// same ten seeds.
template <class F>
std::vector<double> RandomSearchOverSeeds(const ParameterSpace& space, F f, int rounds,
                                          int per_round, double noise_sd) {
  std::vector<double> r;
  for (std::uint64_t seed = 0; seed < 10; ++seed) {
    RandomSearchOptions o;
    o.seed = seed;
    RandomSearch rs(space, o);
    Rng noise(DeriveSeed(seed, {5}));
    for (int k = 0; k < rounds; ++k) {
      const auto c = rs.Ask(per_round);
      std::vector<double> v;
      for (const auto& x : c) v.push_back(f(x.x) + noise_sd * StandardNormal(noise));
      rs.Tell(c, v);
    }
    r.push_back(f(rs.Best()->x));
  }
  std::sort(r.begin(), r.end());
  std::printf("random search regrets: median %.3g min %.3g\n", 0.5 * (r[4] + r[5]), r[0]);
  return r;
}

TEST(PsoPerformance, NoisySphereWithReevaluationReachesRegret) {
  // Sphere 3-D on [-5, 5]^3 with N(0, 0.5²) noise, 150 rounds, personal bests re-evaluated
  // every 4th issue: median 0.059, max 0.51.
  PsoOptions o;
  o.reevaluation_period = 4;
  const auto r = OverSeeds(BoxSpace(3, -5.0, 5.0), Sphere, 150, 0.5, o);
  constexpr double kMedianBound = 0.15;
  EXPECT_LE(r[5], kMedianBound);
  EXPECT_LE(r[9], 1.0);
  // The bound is one that uniform random search with the same 3000 noisy evaluations misses:
  // its median regret lies above it (and so does its best seed's).
  const auto random =
      RandomSearchOverSeeds(BoxSpace(3, -5.0, 5.0), Sphere, 150, o.num_particles, 0.5);
  EXPECT_GT(random[4], kMedianBound);
}

TEST(Pso, PendingParticlesAreNotReissued) {
  PsoOptions o;
  o.num_particles = 4;
  Pso pso(BoxSpace(2, 0.0, 1.0), o);
  const auto a = pso.Ask(3);
  EXPECT_EQ(a.size(), 3u);
  const auto b = pso.Ask(3);
  EXPECT_EQ(b.size(), 1u);  // only one particle was free
  EXPECT_TRUE(pso.Ask(2).empty());
  pso.Tell(a[1].id, 1.0);
  EXPECT_EQ(pso.Ask(5).size(), 1u);
  EXPECT_EQ(pso.NumPending(), 4u);
}

TEST(Pso, OutOfOrderResultsUpdateTheBest) {
  PsoOptions o;
  o.num_particles = 5;
  Pso pso(BoxSpace(2, -1.0, 1.0), o);
  const auto c = pso.Ask(5);
  pso.Tell(c[3].id, 3.0);
  pso.Tell(c[0].id, 1.0);
  pso.Tell(c[4].id, 2.0);
  ASSERT_TRUE(pso.Best().has_value());
  EXPECT_EQ(pso.Best()->id, c[0].id);
  EXPECT_EQ(pso.Best()->x, c[0].x);
  EXPECT_DOUBLE_EQ(pso.Best()->value, 1.0);
  const auto changes = pso.BestChanges();
  pso.Tell(c[2].id, 5.0);
  EXPECT_EQ(pso.BestChanges(), changes);
  pso.Tell(c[1].id, 0.5);
  EXPECT_EQ(pso.BestChanges(), changes + 1);
}

TEST(Pso, MoveFollowsTheUpdateEquationAndClampsVelocity) {
  PsoOptions o;
  o.num_particles = 2;
  o.max_velocity = 0.05;
  Pso pso(BoxSpace(3, 0.0, 1.0), o);
  const auto c = pso.Ask(2);
  pso.Tell(c, {1.0, 0.0});
  const Eigen::VectorXd before = pso.ParticlePosition(0);
  (void)pso.Ask(1);
  const Eigen::VectorXd after = pso.ParticlePosition(0);
  const Eigen::VectorXd v = pso.ParticleVelocity(0);
  EXPECT_LE(v.cwiseAbs().maxCoeff(), 0.05 + 1e-15);
  for (int i = 0; i < 3; ++i) {
    const double moved = after[i] - before[i];
    EXPECT_NEAR(std::abs(moved), std::abs(v[i]), 1e-12);  // θ ← θ + v (or its reflection)
  }
}

TEST(Pso, CandidatesRespectBoundsAndIntegers) {
  Parameter a;
  a.name = "n_pol";
  a.lower = 3;
  a.upper = 12;
  a.type = ParameterType::kInteger;
  Parameter b;
  b.name = "w";
  b.lower = 0.01;
  b.upper = 10;
  b.log_scale = true;
  const ParameterSpace space({a, b});
  Pso pso(space, {});
  for (int r = 0; r < 20; ++r) {
    const auto c = pso.Ask(20);
    std::vector<double> v;
    for (const auto& x : c) {
      EXPECT_TRUE(space.Contains(x.x)) << x.x.transpose();
      v.push_back(std::pow(x.x[0] - 7.0, 2) + std::pow(std::log(x.x[1]), 2));
    }
    pso.Tell(c, v);
  }
  EXPECT_EQ(pso.Best()->x[0], 7.0);
}

TEST(Pso, RestartForgetsBestsAndDropsStaleResults) {
  Pso pso(BoxSpace(2, 0.0, 1.0), {});
  auto c = pso.Ask(20);
  std::vector<double> v(20, 1.0);
  pso.Tell(c, v);
  const auto stale = pso.Ask(3);
  Eigen::VectorXd seed_point(2);
  seed_point << 0.25, 0.75;
  pso.Restart(seed_point);
  EXPECT_FALSE(pso.Best().has_value());
  EXPECT_EQ(pso.NumPending(), 0u);
  pso.Tell(stale[0].id, -100.0);  // accepted, ignored
  EXPECT_FALSE(pso.Best().has_value());
  const auto fresh = pso.Ask(1);
  EXPECT_TRUE(fresh[0].x.isApprox(seed_point));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { pso.Tell(stale[0].id, 1.0); },
      {"unknown candidate id", "already told"}));  // already told
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { pso.Restart(Eigen::VectorXd::Constant(2, 2.0)); },
      {"wrong size or lies outside the space"}));
}

TEST(Pso, CancelledParticleIsReissuedAtTheSamePosition) {
  PsoOptions o;
  o.num_particles = 1;
  Pso pso(BoxSpace(2, 0.0, 1.0), o);
  const auto a = pso.Ask(1);
  pso.Cancel(a[0].id);
  const auto b = pso.Ask(1);
  EXPECT_EQ(a[0].x, b[0].x);
  EXPECT_NE(a[0].id, b[0].id);
}

TEST(Pso, SameSeedSameCandidates) {
  auto run = [](std::uint64_t seed) {
    PsoOptions o;
    o.seed = seed;
    o.num_particles = 6;
    o.reevaluation_period = 3;
    Pso pso(BoxSpace(3, -1.0, 1.0), o);
    std::vector<Eigen::VectorXd> xs;
    for (int r = 0; r < 10; ++r) {
      const auto c = pso.Ask(4);
      std::vector<double> v;
      for (const auto& x : c) {
        xs.push_back(x.x);
        v.push_back(Sphere(x.x));
      }
      std::reverse(v.begin(), v.end());
      std::vector<CandidateId> ids;
      for (auto it = c.rbegin(); it != c.rend(); ++it) ids.push_back(it->id);
      pso.Tell(ids, v);
    }
    return xs;
  };
  EXPECT_EQ(run(1), run(1));
  EXPECT_NE(run(1), run(2));
}

TEST(Pso, SaveRestoreContinuesExactly) {
  PsoOptions o;
  o.num_particles = 7;
  o.reevaluation_period = 2;
  o.seed = 4;
  Pso a(BoxSpace(3, -1.0, 1.0), o);
  for (int r = 0; r < 5; ++r) {
    const auto c = a.Ask(5);
    std::vector<double> v;
    for (const auto& x : c) v.push_back(Sphere(x.x));
    a.Tell(c, v);
  }
  const auto pending = a.Ask(3);
  Pso b(BoxSpace(3, -1.0, 1.0), o);
  b.RestoreState(nlohmann::json::parse(a.SaveState().dump()));
  a.Tell(pending, {0.1, 0.2, 0.3});
  b.Tell(pending, {0.1, 0.2, 0.3});
  for (int r = 0; r < 5; ++r) {
    const auto ca = a.Ask(4);
    const auto cb = b.Ask(4);
    ASSERT_EQ(ca.size(), cb.size());
    std::vector<double> v;
    for (std::size_t j = 0; j < ca.size(); ++j) {
      EXPECT_EQ(ca[j].id, cb[j].id);
      EXPECT_EQ(ca[j].x, cb[j].x);
      v.push_back(Sphere(ca[j].x));
    }
    a.Tell(ca, v);
    b.Tell(cb, v);
  }
  EXPECT_EQ(a.SaveState(), b.SaveState());
}

TEST(Pso, RejectsBadOptions) {
  PsoOptions o;
  o.num_particles = 0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { Pso(BoxSpace(2, 0.0, 1.0), o); },
                                                  "num_particles", {"got 0, allowed: an integer in [1, 1000000]"}));
  o = {};
  o.max_velocity = 0.0;
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError([&] { Pso(BoxSpace(2, 0.0, 1.0), o); },
                                                  "max_velocity", {"got 0, allowed: a number in (0, 1]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { PsoOptions::FromYaml(YamlMap::FromString("inertia: 3")); }, "inertia",
      {"allowed: a number in [0, 1.5]"}));
  EXPECT_TRUE(::quadtune::test::ThrowsConfigError(
      [&] { PsoOptions::FromYaml(YamlMap::FromString("particles: 3")); }, "particles",
      {"unknown key; allowed keys"}));
}

TEST(Pso, RejectsStateWithOtherSwarmSize) {
  PsoOptions o;
  o.num_particles = 3;
  Pso a(BoxSpace(2, 0.0, 1.0), {});
  Pso b(BoxSpace(2, 0.0, 1.0), o);
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>([&] { b.RestoreState(a.SaveState()); },
                                                       {"different number of particles"}));
}

}  // namespace
}  // namespace quadtune::optimizers
