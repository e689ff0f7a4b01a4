#include "quadtune/planning/ipopt/dense_ma27.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <atomic>
#include <cmath>
#include <random>
#include <thread>
#include <vector>

#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>

namespace quadtune::planning {
namespace {

using namespace dense_ma27;

// Drives the four entry points like Ipopt's Ma27TSolverInterface does.
struct Ma27Run {
  int iflag_analysis = 0;
  int iflag_factor = 0;
  int negative = 0;
  int rank_info = 0;
  Eigen::VectorXd x;
};

Ma27Run RunMa27(int n, const std::vector<int>& irn, const std::vector<int>& icn,
                const std::vector<double>& vals, const Eigen::VectorXd& rhs) {
  Ma27Run run;
  int icntl[30];
  double cntl[5];
  Ma27Id(icntl, cntl);
  int nz = static_cast<int>(vals.size());
  int liw = 2 * (2 * nz + 3 * n + 1);
  std::vector<int> iw(static_cast<std::size_t>(liw));
  std::vector<int> ikeep(static_cast<std::size_t>(3 * n));
  std::vector<int> iw1(static_cast<std::size_t>(2 * n));
  int nsteps = 0;
  int iflag = 0;
  int info[20];
  double ops = 0.0;
  Ma27Ad(&n, &nz, irn.data(), icn.data(), iw.data(), &liw, ikeep.data(), iw1.data(), &nsteps,
         &iflag, icntl, cntl, info, &ops);
  run.iflag_analysis = info[0];
  if (info[0] != 0) return run;
  int la = std::max(nz, info[4]);
  liw = info[5];
  std::vector<double> a(static_cast<std::size_t>(la));
  std::copy(vals.begin(), vals.end(), a.begin());
  iw.assign(static_cast<std::size_t>(liw), 0);
  int maxfrt = 0;
  Ma27Bd(&n, &nz, irn.data(), icn.data(), a.data(), &la, iw.data(), &liw, ikeep.data(), &nsteps,
         &maxfrt, iw1.data(), icntl, cntl, info);
  run.iflag_factor = info[0];
  run.negative = info[14];
  run.rank_info = info[1];
  if (info[0] != 0) return run;
  std::vector<double> w(static_cast<std::size_t>(maxfrt));
  std::vector<int> iw1c(static_cast<std::size_t>(nsteps));
  run.x = rhs;
  Ma27Cd(&n, a.data(), &la, iw.data(), &liw, w.data(), &maxfrt, run.x.data(), iw1c.data(), &nsteps,
         icntl, cntl);
  return run;
}

// Triplets of the matrix: a random mix of lower/upper entries, diagonal split in two duplicates.
void ToTriplets(const Eigen::MatrixXd& m, std::mt19937& rng, std::vector<int>* irn,
                std::vector<int>* icn, std::vector<double>* vals) {
  std::bernoulli_distribution coin(0.5);
  const int n = static_cast<int>(m.rows());
  for (int c = 0; c < n; ++c) {
    for (int r = c; r < n; ++r) {
      if (r == c) {
        irn->push_back(r + 1);
        icn->push_back(c + 1);
        vals->push_back(0.25 * m(r, c));
        irn->push_back(r + 1);
        icn->push_back(c + 1);
        vals->push_back(0.75 * m(r, c));
      } else if (m(r, c) != 0.0) {
        const bool upper = coin(rng);
        irn->push_back(upper ? c + 1 : r + 1);
        icn->push_back(upper ? r + 1 : c + 1);
        vals->push_back(m(r, c));
      }
    }
  }
}

TEST(DenseMa27, SolvesRandomIndefiniteSystemsWithCorrectInertia) {
  std::mt19937 rng(42);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 60; ++trial) {
    const int n = 1 + trial % 25;
    Eigen::MatrixXd q = Eigen::MatrixXd::NullaryExpr(n, n, [&] { return normal(rng); });
    q = Eigen::HouseholderQR<Eigen::MatrixXd>(q).householderQ();
    Eigen::VectorXd eig(n);
    int expected_negative = 0;
    for (int i = 0; i < n; ++i) {
      const double mag = std::exp(normal(rng));
      const bool neg = (trial + i) % 3 == 0;
      eig(i) = neg ? -mag : mag;
      expected_negative += neg ? 1 : 0;
    }
    const Eigen::MatrixXd m = q * eig.asDiagonal() * q.transpose();
    // Sparsify a bit for some trials (keeps symmetry; inertia checked against the eigensolver).
    Eigen::MatrixXd ms = m;
    if (trial % 2 == 1) {
      for (int c = 0; c < n; ++c)
        for (int r = c + 1; r < n; ++r)
          if ((r + c + trial) % 4 == 0) ms(r, c) = ms(c, r) = 0.0;
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(ms);
      expected_negative = static_cast<int>((es.eigenvalues().array() < 0.0).count());
      ASSERT_GT(es.eigenvalues().cwiseAbs().minCoeff(), 1e-8) << "test matrix nearly singular";
    }
    std::vector<int> irn;
    std::vector<int> icn;
    std::vector<double> vals;
    ToTriplets(ms, rng, &irn, &icn, &vals);
    const Eigen::VectorXd rhs = Eigen::VectorXd::NullaryExpr(n, [&] { return normal(rng); });
    const Ma27Run run = RunMa27(n, irn, icn, vals, rhs);
    ASSERT_EQ(run.iflag_analysis, 0);
    ASSERT_EQ(run.iflag_factor, 0) << "trial " << trial;
    EXPECT_EQ(run.negative, expected_negative) << "trial " << trial;
    const Eigen::VectorXd reference = ms.fullPivLu().solve(rhs);
    EXPECT_LT((run.x - reference).norm(), 1e-8 * (1.0 + reference.norm())) << "trial " << trial;
    EXPECT_LT((ms * run.x - rhs).norm(), 1e-9 * (1.0 + rhs.norm()));
  }
}

TEST(DenseMa27, ReportsSingularMatrixAsRankDeficient) {
  // [[1, 1], [1, 1]] and an all-zero row/column.
  for (int variant = 0; variant < 2; ++variant) {
    std::vector<int> irn;
    std::vector<int> icn;
    std::vector<double> vals;
    int n = 0;
    if (variant == 0) {
      n = 2;
      irn = {1, 2, 2};
      icn = {1, 1, 2};
      vals = {1.0, 1.0, 1.0};
    } else {
      n = 3;
      irn = {1, 3};
      icn = {1, 3};
      vals = {2.0, -1.0};
    }
    const Ma27Run run = RunMa27(n, irn, icn, vals, Eigen::VectorXd::Ones(n));
    EXPECT_EQ(run.iflag_factor, 3) << "variant " << variant;
    EXPECT_EQ(run.rank_info, n - 1);
  }
}

TEST(DenseMa27, AsksForMoreSpaceLikeMa27) {
  int n = 3;
  int nz = 3;
  std::vector<int> irn{1, 2, 3};
  std::vector<int> icn{1, 2, 3};
  int icntl[30];
  double cntl[5];
  Ma27Id(icntl, cntl);
  int info[20];
  int nsteps = 0;
  int maxfrt = 0;
  std::vector<int> ikeep(9);
  std::vector<int> iw1(6);
  std::vector<double> a(3, 1.0);
  int la = 3;  // too small for the dense factor
  std::vector<int> iw(64);
  int liw = 64;
  Ma27Bd(&n, &nz, irn.data(), icn.data(), a.data(), &la, iw.data(), &liw, ikeep.data(), &nsteps,
         &maxfrt, iw1.data(), icntl, cntl, info);
  EXPECT_EQ(info[0], -4);
  EXPECT_EQ(info[1], nz + n * n);
  std::vector<double> big(64, 1.0);
  la = 64;
  liw = 2;
  Ma27Bd(&n, &nz, irn.data(), icn.data(), big.data(), &la, iw.data(), &liw, ikeep.data(), &nsteps,
         &maxfrt, iw1.data(), icntl, cntl, info);
  EXPECT_EQ(info[0], -3);
  EXPECT_GT(info[1], 2);
}

TEST(DenseMa27, AnalysisFlagsOutOfRangeIndices) {
  int n = 2;
  int nz = 2;
  std::vector<int> irn{1, 3};
  std::vector<int> icn{1, 1};
  std::vector<int> iw(32);
  int liw = 32;
  std::vector<int> ikeep(6);
  std::vector<int> iw1(4);
  int nsteps = 0;
  int iflag = 0;
  int icntl[30];
  double cntl[5];
  int info[20];
  double ops = 0.0;
  Ma27Id(icntl, cntl);
  Ma27Ad(&n, &nz, irn.data(), icn.data(), iw.data(), &liw, ikeep.data(), iw1.data(), &nsteps,
         &iflag, icntl, cntl, info, &ops);
  EXPECT_EQ(info[0], 1);
  EXPECT_EQ(info[1], 1);
}

// Hock–Schittkowski problem 71 (Ipopt's own example): min x1 x4 (x1+x2+x3) + x3
// s.t. x1 x2 x3 x4 >= 25, Σ x_i² = 40, 1 <= x <= 5. Optimum f* = 17.014017...
class Hs071 final : public Ipopt::TNLP {
 public:
  using Index = Ipopt::Index;
  using Number = Ipopt::Number;
  bool get_nlp_info(Index& n, Index& m, Index& nnz_jac_g, Index& nnz_h_lag,
                    IndexStyleEnum& style) override {
    n = 4;
    m = 2;
    nnz_jac_g = 8;
    nnz_h_lag = 10;
    style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Index n, Number* x_l, Number* x_u, Index /*m*/, Number* g_l,
                       Number* g_u) override {
    for (Index i = 0; i < n; ++i) {
      x_l[i] = 1.0;
      x_u[i] = 5.0;
    }
    g_l[0] = 25.0;
    g_u[0] = 2e19;
    g_l[1] = g_u[1] = 40.0;
    return true;
  }
  bool get_starting_point(Index /*n*/, bool /*init_x*/, Number* x, bool /*init_z*/, Number*,
                          Number*, Index /*m*/, bool /*init_lambda*/, Number*) override {
    x[0] = 1.0;
    x[1] = 5.0;
    x[2] = 5.0;
    x[3] = 1.0;
    return true;
  }
  bool eval_f(Index, const Number* x, bool, Number& f) override {
    f = x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2];
    return true;
  }
  bool eval_grad_f(Index, const Number* x, bool, Number* g) override {
    g[0] = x[0] * x[3] + x[3] * (x[0] + x[1] + x[2]);
    g[1] = x[0] * x[3];
    g[2] = x[0] * x[3] + 1.0;
    g[3] = x[0] * (x[0] + x[1] + x[2]);
    return true;
  }
  bool eval_g(Index, const Number* x, bool, Index, Number* g) override {
    g[0] = x[0] * x[1] * x[2] * x[3];
    g[1] = x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3];
    return true;
  }
  bool eval_jac_g(Index, const Number* x, bool, Index, Index, Index* r, Index* c,
                  Number* v) override {
    if (v == nullptr) {
      for (Index k = 0; k < 8; ++k) {
        r[k] = k / 4;
        c[k] = k % 4;
      }
      return true;
    }
    v[0] = x[1] * x[2] * x[3];
    v[1] = x[0] * x[2] * x[3];
    v[2] = x[0] * x[1] * x[3];
    v[3] = x[0] * x[1] * x[2];
    for (Index k = 0; k < 4; ++k) v[4 + k] = 2.0 * x[k];
    return true;
  }
  bool eval_h(Index, const Number* x, bool, Number s, Index, const Number* l, bool, Index,
              Index* r, Index* c, Number* v) override {
    if (v == nullptr) {
      Index k = 0;
      for (Index i = 0; i < 4; ++i)
        for (Index j = 0; j <= i; ++j) {
          r[k] = i;
          c[k] = j;
          ++k;
        }
      return true;
    }
    v[0] = s * 2 * x[3] + l[1] * 2;
    v[1] = s * x[3] + l[0] * x[2] * x[3];
    v[2] = l[1] * 2;
    v[3] = s * x[3] + l[0] * x[1] * x[3];
    v[4] = l[0] * x[0] * x[3];
    v[5] = l[1] * 2;
    v[6] = s * (2 * x[0] + x[1] + x[2]) + l[0] * x[1] * x[2];
    v[7] = s * x[0] + l[0] * x[0] * x[2];
    v[8] = s * x[0] + l[0] * x[0] * x[1];
    v[9] = l[1] * 2;
    return true;
  }
  void finalize_solution(Ipopt::SolverReturn, Index, const Number* x, const Number*,
                         const Number*, Index, const Number*, const Number*, Number obj,
                         const Ipopt::IpoptData*, Ipopt::IpoptCalculatedQuantities*) override {
    objective = obj;
    for (int i = 0; i < 4; ++i) solution[i] = x[i];
  }
  double objective = 0.0;
  double solution[4] = {0, 0, 0, 0};
};

Ipopt::ApplicationReturnStatus SolveHs071(Hs071* problem) {
  RegisterDenseMa27WithIpopt();
  Ipopt::SmartPtr<Ipopt::IpoptApplication> app = new Ipopt::IpoptApplication(false);
  app->Options()->SetIntegerValue("print_level", 0);
  app->Options()->SetStringValue("sb", "yes");
  app->Options()->SetStringValue("linear_solver", "ma27");
  app->Options()->SetStringValue("linear_system_scaling", "none");
  app->Options()->SetNumericValue("tol", 1e-9);
  app->Initialize("");
  return app->OptimizeTNLP(Ipopt::SmartPtr<Ipopt::TNLP>(problem));
}

TEST(DenseMa27, IpoptSolvesHs071ToItsKnownOptimum) {
  Hs071* problem = new Hs071;
  Ipopt::SmartPtr<Ipopt::TNLP> keep(problem);
  ASSERT_EQ(SolveHs071(problem), Ipopt::Solve_Succeeded);
  EXPECT_NEAR(problem->objective, 17.0140171451, 1e-6);
  const double expected[4] = {1.0, 4.7429996, 3.8211499, 1.3794082};
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(problem->solution[i], expected[i], 1e-5);
}

TEST(DenseMa27, ConcurrentIpoptSolvesGiveIdenticalResults) {
  Hs071* reference = new Hs071;
  Ipopt::SmartPtr<Ipopt::TNLP> keep(reference);
  ASSERT_EQ(SolveHs071(reference), Ipopt::Solve_Succeeded);
  for (int threads : {2, 8}) {
    std::atomic<int> mismatches{0};
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) {
      pool.emplace_back([&] {
        for (int k = 0; k < 25; ++k) {
          Hs071* p = new Hs071;
          Ipopt::SmartPtr<Ipopt::TNLP> hold(p);
          if (SolveHs071(p) != Ipopt::Solve_Succeeded || p->objective != reference->objective) {
            ++mismatches;
          }
          for (int i = 0; i < 4; ++i)
            if (p->solution[i] != reference->solution[i]) ++mismatches;
        }
      });
    }
    for (auto& th : pool) th.join();
    EXPECT_EQ(mismatches.load(), 0) << threads << " threads";
  }
}

}  // namespace
}  // namespace quadtune::planning
