// The sweep experiment: the Saltelli design, the Sobol' index estimators on functions with known
// indices, Spearman's correlation, and sweeps of the toy planner (determinism across thread
// counts, common maps, failures recorded, f_s's θ_l indices).
#include "quadtune/engine/tuning/sweep.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <set>

#include "../config_error_util.hpp"
#include "test_util.hpp"

namespace quadtune::engine {
namespace {

using quadtune::test::ThrowsWithMessage;

using quadtune::test::ThrowsConfigError;

/// f at every design point, split into f_A, f_B and f_AB^(i).
struct Evaluated {
  std::vector<double> a, b;
  std::vector<std::vector<double>> ab;
};

template <class F>
Evaluated Evaluate(const SaltelliDesign& design, F f) {
  Evaluated e;
  const int n = design.Rows();
  e.ab.resize(static_cast<std::size_t>(design.Dim()));
  for (int p = 0; p < design.Points(); ++p) {
    const double v = f(design.Point(p));
    const int block = design.Block(p);
    if (block == 0) e.a.push_back(v);
    if (block == 1) e.b.push_back(v);
    if (block >= 2) e.ab[static_cast<std::size_t>(block - 2)].push_back(v);
  }
  EXPECT_EQ(static_cast<int>(e.a.size()), n);
  return e;
}

TEST(SaltelliDesign, BlocksAreAAndBWithOneColumnSwapped) {
  const SaltelliDesign design = MakeSaltelliDesign(16, 3, 9);
  ASSERT_EQ(design.Points(), 16 * 5);
  for (int p = 0; p < design.Points(); ++p) {
    const Eigen::VectorXd x = design.Point(p);
    const int block = design.Block(p);
    const int row = design.Row(p);
    EXPECT_TRUE((x.array() >= 0.0).all() && (x.array() < 1.0).all());
    for (int j = 0; j < 3; ++j) {
      const double expected = block == 1 || block == j + 2 ? design.b(row, j) : design.a(row, j);
      EXPECT_EQ(x[j], expected) << "point " << p << " column " << j;
    }
  }
  // A and B are different halves of the sequence, not copies.
  EXPECT_GT((design.a - design.b).norm(), 0.5);
}

TEST(SaltelliDesign, PlainSequenceStartsAfterTheOriginAndTheShiftIsSeeded) {
  const SaltelliDesign plain = MakeSaltelliDesign(4, 2, 0);
  // Sobol' points 1 and 2 (the origin skipped): (1/2, 1/2, 1/2, 1/2), (3/4, 1/4, ...).
  EXPECT_EQ(plain.a(0, 0), 0.5);
  EXPECT_EQ(plain.b(0, 1), 0.5);
  EXPECT_EQ(plain.a(1, 0), 0.75);
  EXPECT_EQ(plain.a(1, 1), 0.25);
  const SaltelliDesign s1 = MakeSaltelliDesign(8, 2, 1);
  const SaltelliDesign s1_again = MakeSaltelliDesign(8, 2, 1);
  const SaltelliDesign s2 = MakeSaltelliDesign(8, 2, 2);
  EXPECT_EQ(s1.a, s1_again.a);
  EXPECT_EQ(s1.b, s1_again.b);
  EXPECT_NE(s1.a, s2.a);
  // A digital shift keeps the net: each coordinate of the 8 points of sequence indices 8…15
  // (rows 7…14: row r is index r + 1, the origin skipped) still hits every eighth once.
  const SaltelliDesign net = MakeSaltelliDesign(16, 2, 1);
  for (int j = 0; j < 2; ++j) {
    std::set<int> cells;
    for (int r = 7; r < 15; ++r) cells.insert(static_cast<int>(net.a(r, j) * 8));
    EXPECT_EQ(cells.size(), 8u) << "column " << j;
  }
  EXPECT_TRUE(ThrowsConfigError([] { (void)MakeSaltelliDesign(0, 2, 1); }, "points",
                                {"at least 1 base row", "got 0"}));
  EXPECT_TRUE(ThrowsConfigError([] { (void)MakeSaltelliDesign(4, 0, 1); }, "parameters",
                                {"1 to 1833 parameters", "got 0"}));
}

// Ishigami, a = 7, b = 0.1, x ∈ [−π, π]³: S1 = (0.314, 0.442, 0), ST = (0.558, 0.442, 0.244).
TEST(SobolIndices, IshigamiRecoveredWithinTolerance) {
  const SaltelliDesign design = MakeSaltelliDesign(4096, 3, 17);
  const Evaluated f = Evaluate(design, [](const Eigen::VectorXd& u) {
    const Eigen::ArrayXd x = (2.0 * u.array() - 1.0) * std::numbers::pi;
    return std::sin(x[0]) + 7.0 * std::pow(std::sin(x[1]), 2) +
           0.1 * std::pow(x[2], 4) * std::sin(x[0]);
  });
  const SobolIndices s = EstimateSobolIndices(f.a, f.b, f.ab, 300, 5);
  const double s1[] = {0.3139, 0.4424, 0.0};
  const double st[] = {0.5576, 0.4424, 0.2437};
  const double tolerance = 0.05;
  ASSERT_EQ(s.index.size(), 3u);
  // Analytic variance: a²/8 + b π⁴/5 + b² π⁸/18 + 1/2.
  const double pi4 = std::pow(std::numbers::pi, 4);
  EXPECT_NEAR(s.variance, 49.0 / 8 + 0.1 * pi4 / 5 + 0.01 * pi4 * pi4 / 18 + 0.5, 0.3);
  for (int i = 0; i < 3; ++i) {
    const SobolIndex& x = s.index[static_cast<std::size_t>(i)];
    EXPECT_NEAR(x.s1, s1[i], tolerance) << "S1 of x" << i + 1;
    EXPECT_NEAR(x.st, st[i], tolerance) << "ST of x" << i + 1;
    // Finite intervals around the estimates, and narrow at this N.
    EXPECT_LT(x.s1_lo, x.s1_hi);
    EXPECT_LT(x.st_lo, x.st_hi);
    EXPECT_LT(x.s1_hi - x.s1_lo, 0.15);
    EXPECT_LT(x.st_hi - x.st_lo, 0.15);
    EXPECT_LE(x.st_lo, st[i] + 0.01);
    EXPECT_GE(x.st_hi, st[i] - 0.01);
  }
}

// f = Σ c_i u_i with u uniform: additive, so S1 = ST = c_i² / Σ c_j²; c = (1, 2, 3, 0).
TEST(SobolIndices, LinearFunctionMatchesAnalyticIndices) {
  const SaltelliDesign design = MakeSaltelliDesign(1024, 4, 3);
  const Eigen::Vector4d c(1.0, 2.0, 3.0, 0.0);
  const Evaluated f = Evaluate(design, [&](const Eigen::VectorXd& u) { return c.dot(u); });
  const SobolIndices s = EstimateSobolIndices(f.a, f.b, f.ab, 200, 1);
  EXPECT_NEAR(s.variance, 14.0 / 12.0, 0.02);
  for (int i = 0; i < 4; ++i) {
    const double exact = c[i] * c[i] / 14.0;
    const SobolIndex& x = s.index[static_cast<std::size_t>(i)];
    EXPECT_NEAR(x.s1, exact, 0.02) << i;
    EXPECT_NEAR(x.st, exact, 0.02) << i;
  }
  // The inert parameter: f_AB equals f_A exactly, so both estimators give exactly 0.
  EXPECT_EQ(s.index[3].s1, 0.0);
  EXPECT_EQ(s.index[3].st, 0.0);
}

TEST(SobolIndices, ConstantOutputHasNoIndicesAndBadSizesThrow) {
  const std::vector<double> one(8, 1.0);
  const SobolIndices s = EstimateSobolIndices(one, one, {one, one}, 10, 1);
  EXPECT_EQ(s.variance, 0.0);
  for (const auto& x : s.index) {
    EXPECT_TRUE(std::isnan(x.s1) && std::isnan(x.st) && std::isnan(x.s1_lo));
  }
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        (void)EstimateSobolIndices(one, {1.0, 2.0}, {one}, 10, 1);
      },
      {"f_a and f_b need the same N"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { (void)EstimateSobolIndices(one, one, {{1.0}}, 10, 1); },
      {"every f_ab needs N values"}));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] { (void)EstimateSobolIndices({1.0}, {1.0}, {}, 10, 1); },
      {"need the same N >= 2 values"}));
}

TEST(SobolIndices, BootstrapIsSeeded) {
  const SaltelliDesign design = MakeSaltelliDesign(64, 2, 3);
  const Evaluated f =
      Evaluate(design, [](const Eigen::VectorXd& u) { return u[0] + u[1] * u[1] * u[0]; });
  const SobolIndices a = EstimateSobolIndices(f.a, f.b, f.ab, 100, 7);
  const SobolIndices b = EstimateSobolIndices(f.a, f.b, f.ab, 100, 7);
  const SobolIndices c = EstimateSobolIndices(f.a, f.b, f.ab, 100, 8);
  EXPECT_EQ(a.index[0].s1_lo, b.index[0].s1_lo);
  EXPECT_EQ(a.index[1].st_hi, b.index[1].st_hi);
  EXPECT_NE(a.index[0].s1_lo, c.index[0].s1_lo);
  EXPECT_EQ(a.index[0].s1, c.index[0].s1);  // the point estimate does not depend on the seed
}

TEST(Spearman, RanksWithTies) {
  EXPECT_DOUBLE_EQ(SpearmanCorrelation({1, 2, 3, 4}, {10, 20, 30, 1000}), 1.0);
  EXPECT_DOUBLE_EQ(SpearmanCorrelation({1, 2, 3, 4}, {4, 3, 2, 1}), -1.0);
  // x ranks (1, 2.5, 2.5, 4), y ranks (1, 3, 2, 4): Pearson of the ranks = 4.5 / sqrt(4.5 · 5).
  EXPECT_NEAR(SpearmanCorrelation({1, 2, 2, 3}, {1, 3, 2, 4}), 4.5 / std::sqrt(4.5 * 5.0), 1e-12);
  EXPECT_TRUE(std::isnan(SpearmanCorrelation({1, 1, 1}, {1, 2, 3})));
  EXPECT_TRUE(ThrowsWithMessage<std::invalid_argument>(
      [&] {
        (void)SpearmanCorrelation({1, 2}, {1});
      },
      {"SpearmanCorrelation", "sizes differ"}));
}

SweepOptions SmallSweep(int threads) {
  SweepOptions o;
  o.points = 8;
  o.maps = 2;
  o.queries = 6;
  o.seed = 42;
  o.threads = threads;
  o.bootstrap = 50;
  return o;
}

/// Every deterministic field of a sweep, as text.
std::vector<std::string> Fingerprint(const SweepResult& r) {
  std::vector<std::string> rows;
  for (const auto& f : r.flights) {
    std::string row = std::to_string(f.point) + "|" + std::to_string(f.map) + "|" +
                      std::to_string(f.map_seed) + "|" + std::to_string(f.flight_seed) + "|" +
                      ToString(f.status) + "|" + f.message + "|" +
                      std::to_string(f.objective.value);
    for (const auto& [k, v] : f.objective.terms) row += "|" + k + "=" + std::to_string(v);
    rows.push_back(row);
  }
  for (const auto& p : r.points)
    rows.push_back(std::to_string(p.f_s) + "|" + std::to_string(p.f_l));
  for (const auto& o : r.outputs) {
    for (const auto& x : o.indices.index) {
      rows.push_back(o.name + "|" + std::to_string(x.s1) + "|" + std::to_string(x.st_lo));
    }
  }
  return rows;
}

TEST(Sweep, ToySweepIsIdenticalAtOneAndTwoThreads) {
  const Experiment e = Experiment::FromString(test::ToyYaml());
  const SweepResult one = RunSweep(e, SmallSweep(1));
  const SweepResult two = RunSweep(e, SmallSweep(2));
  ASSERT_EQ(one.status, RunStatus::kCompleted);
  const int d = e.space.Dim();
  ASSERT_EQ(one.points.size(), static_cast<std::size_t>(8 * (d + 2)));
  ASSERT_EQ(one.flights.size(), one.points.size() * 2);
  EXPECT_EQ(Fingerprint(one), Fingerprint(two));
  // Another seed gives another sweep.
  SweepOptions other = SmallSweep(2);
  other.seed = 43;
  EXPECT_NE(Fingerprint(one), Fingerprint(RunSweep(e, other)));
}

TEST(Sweep, PointsShareTheMapsAndStayInTheBox) {
  const Experiment e = Experiment::FromString(test::ToyYaml());
  const SweepResult r = RunSweep(e, SmallSweep(2));
  ASSERT_EQ(r.map_seeds.size(), 2u);
  EXPECT_NE(r.map_seeds[0], r.map_seeds[1]);
  std::set<std::uint64_t> flight_seeds;
  for (const auto& f : r.flights) {
    EXPECT_EQ(f.map_seed, r.map_seeds[static_cast<std::size_t>(f.map)]);
    flight_seeds.insert(f.flight_seed);
    EXPECT_EQ(f.status, EvalStatus::kOk) << f.message;
  }
  EXPECT_EQ(flight_seeds.size(), r.flights.size());  // one seed per (point, map)
  for (const auto& p : r.points) {
    EXPECT_TRUE(e.space.Contains(e.space.FromNamed(p.params)));
    EXPECT_EQ(p.params.at("max_iter"), std::round(p.params.at("max_iter")));
    // f_l of a point is the mean of its flights' f_l.
  }
  for (std::size_t p = 0; p < r.points.size(); ++p) {
    const double mean =
        0.5 * (r.flights[2 * p].objective.value + r.flights[2 * p + 1].objective.value);
    EXPECT_DOUBLE_EQ(r.points[p].f_l, mean);
  }
  EXPECT_EQ(r.queries_used, std::min(6, r.queries_recorded));
  EXPECT_GT(r.queries_used, 0);
  // θ_s = {gain, max_iter}: the A, B and two A_B^(i) blocks over θ_s vary it; θ_l's blocks don't.
  EXPECT_LE(r.distinct_short, 8 * 4);
  EXPECT_EQ(r.resolves, static_cast<long>(r.distinct_short) * r.queries_used);
  // Outputs and their indices: f_s does not depend on θ_l (exactly 0), f_l does on speed.
  ASSERT_EQ(r.outputs.size(), SweepOutputNames().size());
  for (const auto& o : r.outputs) {
    if (o.name != "f_s") continue;
    for (const char* name : {"speed", "margin"}) {
      const auto i = static_cast<std::size_t>(e.space.IndexOf(name));
      EXPECT_EQ(o.indices.index[i].s1, 0.0);
      EXPECT_EQ(o.indices.index[i].st, 0.0);
    }
    const auto gain = static_cast<std::size_t>(e.space.IndexOf("gain"));
    const auto iters = static_cast<std::size_t>(e.space.IndexOf("max_iter"));
    EXPECT_GT(o.indices.index[gain].st + o.indices.index[iters].st, 0.1);
  }
  EXPECT_TRUE(std::isfinite(r.spearman_fs_fl));
}

TEST(Sweep, FailedFlightsAreRecordedNotThrown) {
  // The toy planner throws above speed 4 m/s: about 2/5.5 of the box.
  const Experiment e =
      Experiment::FromString(test::ToyYaml("[default]", ", throw_speed_above: 4.0"));
  const SweepResult r = RunSweep(e, SmallSweep(2));
  ASSERT_EQ(r.status, RunStatus::kCompleted);
  int failed = 0;
  for (const auto& f : r.flights) {
    const double speed = r.points[static_cast<std::size_t>(f.point)].params.at("speed");
    EXPECT_EQ(f.status == EvalStatus::kFailed, speed > 4.0) << speed;
    if (f.status == EvalStatus::kFailed) {
      ++failed;
      EXPECT_EQ(f.objective.value, e.objective.failure_value);
      EXPECT_NE(f.message.find("exception"), std::string::npos) << f.message;
    }
  }
  EXPECT_GT(failed, 0);
  EXPECT_LT(failed, static_cast<int>(r.flights.size()));
}

TEST(Sweep, BadOptionsNameTheOption) {
  const Experiment e = Experiment::FromString(test::ToyYaml());
  SweepOptions o = SmallSweep(1);
  o.points = 1;
  EXPECT_TRUE(ThrowsConfigError([&] { (void)RunSweep(e, o); }, "--points",
                                {"at least 2 base rows", "got 1"}));
  o = SmallSweep(1);
  o.queries = 0;
  EXPECT_TRUE(
      ThrowsConfigError([&] { (void)RunSweep(e, o); }, "--queries", {"at least 1 query", "got 0"}));
}

}  // namespace
}  // namespace quadtune::engine
