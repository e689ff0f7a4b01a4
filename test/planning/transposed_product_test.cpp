#include "quadtune/planning/ipopt/transposed_product.hpp"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstring>
#include <random>
#include <vector>

namespace quadtune::planning::detail {
namespace {

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Entries of mixed sign and magnitude, with exact zeros, as the active samples' rows have.
Eigen::MatrixXd RandomPanel(int rows, int cols, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> e(-6, 6);
  Eigen::MatrixXd x(rows, cols);
  for (int j = 0; j < cols; ++j) {
    for (int i = 0; i < rows; ++i) {
      const double v = u(*rng);
      x(i, j) = std::abs(v) < 0.05 ? 0.0 : std::ldexp(v, e(*rng));
    }
  }
  return x;
}

std::vector<double> ByRows(const Eigen::MatrixXd& x, int stride) {
  std::vector<double> out(static_cast<std::size_t>(x.rows() * stride), 0.0);
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    for (Eigen::Index j = 0; j < x.cols(); ++j)
      out[static_cast<std::size_t>(i * stride + j)] = x(i, j);
  }
  return out;
}

// Every size it claims, against Eigen's `block += lᵀ * r` on the layouts MinJerkProblem uses
// (column-major operands, the destination a block of a larger matrix); the padding lanes hold
// garbage that must not reach the result.
// Builds whose Eigen kernel is another (AVX, FMA) disable the kernel: Eigen's product runs.
bool KernelEnabled() { return TransposedProductApplies(20, 8, 8); }

TEST(TransposedProduct, GivesTheBitsOfEigensProductAtEverySizeItClaims) {
  if (!KernelEnabled()) GTEST_SKIP() << "this build's Eigen kernel is not the SSE2 one";
  std::mt19937_64 rng(11);
  int checked = 0;
  for (int m = 2; m <= kTransposedProductMaxRows; ++m) {
    for (int n = 2; n <= kTransposedProductMaxRows; ++n) {
      for (int k = 1; k < 64; ++k) {
        if (!TransposedProductApplies(k, m, n)) continue;
        const Eigen::MatrixXd l = RandomPanel(k, m, &rng);
        const Eigen::MatrixXd r = RandomPanel(k, n, &rng);
        const Eigen::MatrixXd base = RandomPanel(m + 3, n + 2, &rng);
        Eigen::MatrixXd expected = base;
        expected.block(1, 2, m, n).noalias() += l.transpose() * r;

        const int ldl = TransposedProductStride(m);
        std::vector<double> lr = ByRows(l, ldl);
        for (int i = 0; i < k; ++i) {
          for (int c = m; c < ldl; ++c) lr[static_cast<std::size_t>(i * ldl + c)] = 1e300;
        }
        const std::vector<double> rr = ByRows(r, n);
        Eigen::MatrixXd got = base;
        AddTransposedProduct(k, m, n, lr.data(), ldl, rr.data(), n, &got(1, 2),
                             static_cast<int>(got.rows()), /*lower_only=*/false);
        for (Eigen::Index j = 0; j < got.cols(); ++j) {
          for (Eigen::Index i = 0; i < got.rows(); ++i) {
            ASSERT_TRUE(SameBits(got(i, j), expected(i, j)))
                << "k " << k << " m " << m << " n " << n << " entry (" << i << ", " << j
                << "): " << got(i, j) << " vs Eigen's " << expected(i, j);
          }
        }
        if (m == n) {  // lower_only: the lower triangle as above, the rest untouched
          Eigen::MatrixXd lower = base;
          AddTransposedProduct(k, m, n, lr.data(), ldl, rr.data(), n, &lower(1, 2),
                               static_cast<int>(lower.rows()), /*lower_only=*/true);
          for (int j = 0; j < n; ++j) {
            for (int i = 0; i < m; ++i) {
              const double want = i >= j ? expected(1 + i, 2 + j) : base(1 + i, 2 + j);
              ASSERT_TRUE(SameBits(lower(1 + i, 2 + j), want))
                  << "lower_only, k " << k << " m " << m << " entry (" << i << ", " << j << ")";
            }
          }
        }
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 4000);
}

TEST(TransposedProduct, DeclinesTheSizesWhereEigenSumsInAnotherOrder) {
  if (!KernelEnabled()) GTEST_SKIP() << "this build's Eigen kernel is not the SSE2 one";
  EXPECT_FALSE(TransposedProductApplies(5, 7, 7));  // coefficient-wise product (5 + 14 < 20)
  EXPECT_TRUE(TransposedProductApplies(6, 7, 7));
  EXPECT_FALSE(TransposedProductApplies(30, 1, 3));  // a single row: Eigen's matrix–vector path
  EXPECT_FALSE(TransposedProductApplies(30, 5, 1));
  EXPECT_FALSE(TransposedProductApplies(48, 5, 5));  // depth Eigen may split into cache blocks
  EXPECT_FALSE(TransposedProductApplies(30, kTransposedProductMaxRows + 1, 3));
}

}  // namespace
}  // namespace quadtune::planning::detail
