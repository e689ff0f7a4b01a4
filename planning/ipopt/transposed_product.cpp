#include "quadtune/planning/ipopt/transposed_product.hpp"

#include <Eigen/Core>
#include <cstring>
#include <utility>

#include "quadtune/common/error.hpp"

namespace quadtune::planning::detail {
namespace {

// Four lanes of doubles (two SSE2 registers, one AVX register in the AVX2 clone): lane-wise
// products and sums, the same operations either way.
typedef double Lanes4 __attribute__((vector_size(32)));

// Depth below which Eigen's blocking heuristic returns early and keeps the whole depth in one
// block (evaluateProductBlockingSizesHeuristic: max(k, m, n) < 48), whatever the cache sizes.
constexpr int kMaxDepth = 48;

// The kernel reproduces gebp_kernel as compiled for SSE2 doubles without FMA: packets of two
// rows, four rows at most per panel (mr = 4), four-column panels, separate multiply and add.
// Other builds keep Eigen's product.
#if defined(EIGEN_VECTORIZE_SSE2) && !defined(EIGEN_VECTORIZE_AVX) && !defined(EIGEN_VECTORIZE_FMA)
using GebpTraits = Eigen::internal::gebp_traits<double, double>;
constexpr bool kReplicatesEigen =
    GebpTraits::LhsProgress == 2 && GebpTraits::mr == 4 && GebpTraits::nr == 4;
#else
constexpr bool kReplicatesEigen = false;
#endif

// gebp_kernel's row panels with mr = 4: rows [0, mc2) in four-row panels, [mc2, mc1) in one
// two-row panel (lhs_process_one_packet, the one whose sums are split), [mc1, m) one at a time.
// mc2 is a multiple of 4: the split rows are lanes 0 and 1 of lane group mc2 / 4.
struct RowPanels {
  int mc2;
  int mc1;
};

RowPanels PanelsOf(int m) {
  const int mc2 = m / 4 * 4;
  return {mc2, mc2 + (m - mc2) / 2 * 2};
}

// acc += p[0..4) · s, lane-wise.
inline __attribute__((always_inline)) void AddScaled(Lanes4* acc, const double* p, double s) {
  Lanes4 v;
  std::memcpy(&v, p, sizeof v);
  *acc += v * s;
}

template <int G>
inline __attribute__((always_inline)) void KernelBody(int k, int m, int n, const double* l, int ldl,
                                                      const double* r, int ldr, double* dst,
                                                      int ldd, bool lower_only) {
  const RowPanels panels = PanelsOf(m);
  const int split_group = panels.mc1 > panels.mc2 ? panels.mc2 / 4 : -1;
  const int nc4 = n / 4 * 4;  // columns in gebp's four-column panels
  const int peeled = k & ~7;  // gebp's depth peeled by 8
  for (int j = 0; j < n; ++j) {
    Lanes4 acc[G];
    for (int g = 0; g < G; ++g) acc[g] = Lanes4{0.0, 0.0, 0.0, 0.0};
    double sums[4 * G];
    if (split_group >= 0 && j < nc4) {
      // The two-row panel in a four-column panel sums even and odd k apart over the peeled
      // depth, adds the two, then goes on one k at a time; the other rows sum in order.
      Lanes4 even = {0.0, 0.0, 0.0, 0.0};
      Lanes4 odd = even;
      int kk = 0;
      for (; kk < peeled; kk += 2) {
        const double s0 = r[kk * ldr + j];
        const double s1 = r[(kk + 1) * ldr + j];
        const double* l0 = l + kk * ldl;
        const double* l1 = l0 + ldl;
        for (int g = 0; g < G; ++g) AddScaled(&acc[g], l0 + 4 * g, s0);
        AddScaled(&even, l0 + 4 * split_group, s0);
        for (int g = 0; g < G; ++g) AddScaled(&acc[g], l1 + 4 * g, s1);
        AddScaled(&odd, l1 + 4 * split_group, s1);
      }
      Lanes4 split = even + odd;
      for (; kk < k; ++kk) {
        const double s = r[kk * ldr + j];
        const double* lk = l + kk * ldl;
        for (int g = 0; g < G; ++g) AddScaled(&acc[g], lk + 4 * g, s);
        AddScaled(&split, lk + 4 * split_group, s);
      }
      std::memcpy(sums, acc, sizeof sums);
      sums[panels.mc2] = split[0];
      sums[panels.mc2 + 1] = split[1];
    } else {
      for (int kk = 0; kk < k; ++kk) {
        const double s = r[kk * ldr + j];
        const double* lk = l + kk * ldl;
        for (int g = 0; g < G; ++g) AddScaled(&acc[g], lk + 4 * g, s);
      }
      std::memcpy(sums, acc, sizeof sums);
    }
    double* col = dst + static_cast<std::ptrdiff_t>(j) * ldd;
    for (int i = lower_only ? j : 0; i < m; ++i) col[i] += sums[i];
  }
}

// The body for the lane-group count of m, inlined into each clone: an AVX2 clone picked at load
// time (left out under TSan, whose runtime is not up when the clones' resolvers run).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__SANITIZE_THREAD__)
__attribute__((target_clones("avx2", "default")))
#endif
void Kernel(int k, int m, int n, const double* l, int ldl, const double* r, int ldr, double* dst,
            int ldd, bool lower_only) {
  // KernelBody<G> for G = ⌈m / 4⌉ lane groups, each body inlined into this clone.
  const int groups = TransposedProductStride(m) / 4;
  [&]<int... G>(std::integer_sequence<int, G...>) __attribute__((always_inline)) {
    ((groups == G + 1 ? KernelBody<G + 1>(k, m, n, l, ldl, r, ldr, dst, ldd, lower_only) : void()),
     ...);
  }
  (std::make_integer_sequence<int, kTransposedProductMaxRows / 4>{});
}

}  // namespace

bool TransposedProductApplies(int k, int m, int n) {
  return kReplicatesEigen && k >= 1 && k < kMaxDepth && m >= 2 && n >= 2 &&
         m <= kTransposedProductMaxRows && k + m + n >= EIGEN_GEMM_TO_COEFFBASED_THRESHOLD;
}

void AddTransposedProduct(int k, int m, int n, const double* l, int ldl, const double* r, int ldr,
                          double* dst, int ldd, bool lower_only) {
  QT_DEMAND(TransposedProductApplies(k, m, n), "AddTransposedProduct: size out of its range");
  QT_DEMAND(ldl % 4 == 0 && ldl >= TransposedProductStride(m), "AddTransposedProduct: bad ldl");
  Kernel(k, m, n, l, ldl, r, ldr, dst, ldd, lower_only);
}

}  // namespace quadtune::planning::detail
