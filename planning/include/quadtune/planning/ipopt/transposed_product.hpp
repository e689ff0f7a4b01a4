#pragma once
/// \file
/// `dst += lᵀ r` for the small products of the cost's derivatives, with the bits of Eigen's own
/// product and without its per-call packing.
///
/// The derivative pass of `MinJerkProblem::Evaluate` multiplies the few active samples' rows of
/// S_d (K of them, K ≈ 12) into m × m and m × 3 blocks (m ≤ 11 inner waypoints), and its value
/// pass computes H̄ b (nb × nb times nb × 3, nb ≤ 17). Eigen evaluates each such product through
/// its general blocked kernel, whose packing and dispatch cost more than the arithmetic at these
/// sizes. `AddTransposedProduct` computes the same sums, each in the
/// order Eigen 3.4's kernel (`gebp_kernel`, SSE2 doubles, no FMA) adds them, so every result keeps
/// its bits. That order, per entry (i, j) of the m × n result:
///  - products k = 0…K−1 summed one after the other from +0, then added to dst(i, j);
///  - except in the kernel's single two-row panel (rows 4⌊m/4⌋ and the next, when m mod 4 ≥ 2)
///    for the columns of its four-column panels (j < 4⌊n/4⌋): there the first K & ~7 products go
///    alternately to two sums (even k, odd k), which are added, and the rest follow one by one.
/// `TransposedProductApplies` says for which sizes this holds: where Eigen itself runs the blocked
/// kernel (K + m + n ≥ EIGEN_GEMM_TO_COEFFBASED_THRESHOLD, m, n ≥ 2), with K below the size at
/// which Eigen would split the depth into cache blocks, in a build whose Eigen kernel is the one
/// described (SSE2, no AVX or FMA: x86-64's baseline, as this project builds). Elsewhere the caller
/// keeps Eigen's product. `planning_tests` compares the bits against Eigen's product over all these
/// sizes.
///
/// Thread safety: pure functions.

namespace quadtune::planning::detail {

/// Largest m (result rows) handled: five groups of four lanes.
inline constexpr int kTransposedProductMaxRows = 20;

/// True where `AddTransposedProduct` gives the bits of Eigen's `dst += lᵀ * r` for a k × m l and
/// a k × n r (both Eigen::MatrixXd, dst a block of one).
[[nodiscard]] bool TransposedProductApplies(int k, int m, int n);

/// dst(i, j) += Σ_k l[k·ldl + i] · r[k·ldr + j] for i < m, j < n, dst stored by columns with
/// leading dimension ldd. l is stored by rows with ldl a multiple of 4, ≥ m rounded up to 4; its
/// padding lanes are read but never reach dst. With `lower_only`, only the entries with i ≥ j are
/// written (for a block on the diagonal of a matrix mirrored afterwards). Precondition:
/// TransposedProductApplies(k, m, n).
void AddTransposedProduct(int k, int m, int n, const double* l, int ldl, const double* r, int ldr,
                          double* dst, int ldd, bool lower_only);

/// m rounded up to a multiple of 4: the row stride of an l panel.
[[nodiscard]] constexpr int TransposedProductStride(int m) { return (m + 3) / 4 * 4; }

}  // namespace quadtune::planning::detail
