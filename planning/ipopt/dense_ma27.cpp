#include "quadtune/planning/ipopt/dense_ma27.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <mutex>

#include <coin/HSLLoader.h>

extern "C" {
// Reference LAPACK (Fortran); the trailing size_t is the hidden length of the CHARACTER argument.
void dsytrf_(const char* uplo, const int* n, double* a, const int* lda, int* ipiv, double* work,
             const int* lwork, int* info, std::size_t uplo_len);
void dsytrs_(const char* uplo, const int* n, const int* nrhs, const double* a, const int* lda,
             const int* ipiv, double* b, const int* ldb, int* info, std::size_t uplo_len);
}

namespace quadtune::planning {
namespace dense_ma27 {
namespace {

// Layout of IW after Ma27Bd (0-based): [0] magic, [1] n, [2] offset of the dense factor in A,
// [3] factorisation state (1 = usable factor), [4, 4 + n) LAPACK pivots.
constexpr int kMagic = 0x4D413237;  // "MA27"
constexpr int kHeader = 4;

int RealSpaceNeeded(int n, int nz) { return nz + n * n; }
int IntSpaceNeeded(int n) { return kHeader + n; }

void ClearInfo(int* info) { std::fill(info, info + 20, 0); }

// Scatters the triplets (1-based irn, icn; values a) into the lower triangle of the dense
// column-major dim × dim matrix `dense` (LAPACK's "L" routines never read the strict upper
// triangle). Returns the number of out-of-range triplets (ignored).
int ScatterLower(int dim, int nnz, const int* irn, const int* icn, const double* a, double* dense) {
  for (int c = 0; c < dim; ++c) {
    double* column = dense + static_cast<std::ptrdiff_t>(c) * dim;
    std::fill(column + c, column + dim, 0.0);
  }
  int out_of_range = 0;
  for (int k = 0; k < nnz; ++k) {
    const int i = irn[k];
    const int j = icn[k];
    if (static_cast<unsigned>(i - 1) >= static_cast<unsigned>(dim) ||
        static_cast<unsigned>(j - 1) >= static_cast<unsigned>(dim)) {
      ++out_of_range;
      continue;
    }
    const int r = std::max(i, j) - 1;
    const int c = std::min(i, j) - 1;
    dense[r + static_cast<std::ptrdiff_t>(c) * dim] += a[k];
  }
  return out_of_range;
}

// The largest magnitude in the lower triangle of `dense` into *max_abs; whether every entry is
// finite (0·v is 0 for finite v, NaN for an infinity or NaN).
bool LowerIsFinite(int dim, const double* dense, double* max_abs) {
  *max_abs = 0.0;
  double nonfinite = 0.0;
  for (int c = 0; c < dim; ++c) {
    const double* column = dense + static_cast<std::ptrdiff_t>(c) * dim;
    for (int r = c; r < dim; ++r) {
      const double v = column[r];
      nonfinite += 0.0 * v;
      *max_abs = std::max(*max_abs, std::abs(v));
    }
  }
  return nonfinite == 0.0;
}

// Inertia and rank from the 1×1 and 2×2 blocks of D in dsytrf's factor `dense` (pivots `ipiv`):
// the negative eigenvalues into *negative, the (numerically, below `tiny`) zero ones into *zero.
void CountInertia(int dim, const double* dense, const int* ipiv, double tiny, int* negative,
                  int* zero) {
  *negative = 0;
  *zero = 0;
  for (int k = 0; k < dim;) {
    const double d11 = dense[k + static_cast<std::ptrdiff_t>(k) * dim];
    if (ipiv[k] > 0 || k + 1 == dim) {
      if (std::abs(d11) <= tiny) {
        ++*zero;
      } else if (d11 < 0.0) {
        ++*negative;
      }
      k += 1;
    } else {
      const double d21 = dense[(k + 1) + static_cast<std::ptrdiff_t>(k) * dim];
      const double d22 = dense[(k + 1) + static_cast<std::ptrdiff_t>(k + 1) * dim];
      const double det = d11 * d22 - d21 * d21;
      const double scale = std::max({std::abs(d11), std::abs(d21), std::abs(d22)});
      if (std::abs(det) <= tiny * scale) {
        // At least one eigenvalue of the block is (numerically) zero.
        ++*zero;
        const double trace = d11 + d22;
        if (trace < -tiny) ++*negative;
        if (std::abs(trace) <= tiny) ++*zero;
      } else if (det < 0.0) {
        ++*negative;  // one positive and one negative eigenvalue
      } else if (d11 + d22 < 0.0) {
        *negative += 2;
      }
      k += 2;
    }
  }
}

}  // namespace

void Ma27Id(int* icntl, double* cntl) {
  // The MA27 defaults (printing streams, pivoting parameters); the dense solver reads only
  // CNTL(3) (absolute zero-pivot threshold).
  std::fill(icntl, icntl + 30, 0);
  icntl[0] = 6;   // error stream
  icntl[1] = 6;   // diagnostic stream
  icntl[2] = 0;   // print level
  icntl[3] = 2139062143;
  icntl[4] = 1;
  std::fill(icntl + 5, icntl + 9, 32639);
  icntl[9] = 14;
  cntl[0] = 0.1;  // relative pivot tolerance (Bunch–Kaufman uses its own fixed alpha)
  cntl[1] = 1.0;  // fratio
  cntl[2] = 0.0;  // pivots of modulus <= CNTL(3) are zero
  cntl[3] = 0.0;
  cntl[4] = 0.0;
}

void Ma27Ad(int* n, int* nz, const int* irn, const int* icn, int* /*iw*/, int* /*liw*/,
            int* ikeep, int* /*iw1*/, int* nsteps, int* iflag, int* /*icntl*/, double* /*cntl*/,
            int* info, double* ops) {
  ClearInfo(info);
  *nsteps = 1;
  *ops = 0.0;
  if (*n < 1) {
    info[0] = -1;
    info[1] = *n;
    return;
  }
  if (*nz < 0) {
    info[0] = -2;
    info[1] = *nz;
    return;
  }
  int out_of_range = 0;
  for (int k = 0; k < *nz; ++k) {
    if (irn[k] < 1 || irn[k] > *n || icn[k] < 1 || icn[k] > *n) ++out_of_range;
  }
  if (out_of_range > 0) {
    info[0] = 1;  // MA27's warning for out-of-range entries (they are ignored)
    info[1] = out_of_range;
  }
  // Identity pivot order (the dense factorisation pivots by itself); IKEEP(1:N) as MA27 keeps it.
  if (*iflag == 0) {
    for (int i = 0; i < *n; ++i) ikeep[i] = i + 1;
  }
  info[4] = RealSpaceNeeded(*n, *nz);  // INFO(5): LA for MA27BD
  info[5] = IntSpaceNeeded(*n);        // INFO(6): LIW for MA27BD
  info[6] = 0;
  info[7] = 0;
  info[8] = 0;
  const double dn = static_cast<double>(*n);
  *ops = dn * dn * dn / 3.0;
}

void Ma27Bd(int* n, int* nz, const int* irn, const int* icn, double* a, int* la, int* iw,
            int* liw, int* /*ikeep*/, int* nsteps, int* maxfrt, int* /*iw1*/, int* /*icntl*/,
            double* cntl, int* info) {
  ClearInfo(info);
  const int dim = *n;
  const int nnz = *nz;
  if (dim < 1) {
    info[0] = -1;
    info[1] = dim;
    return;
  }
  if (nnz < 0) {
    info[0] = -2;
    info[1] = nnz;
    return;
  }
  if (*liw < IntSpaceNeeded(dim)) {
    info[0] = -3;
    info[1] = IntSpaceNeeded(dim);
    return;
  }
  if (*la < RealSpaceNeeded(dim, nnz)) {
    info[0] = -4;
    info[1] = RealSpaceNeeded(dim, nnz);
    return;
  }
  *nsteps = 1;
  *maxfrt = dim;

  // The dense matrix lies after the input values.
  double* dense = a + nnz;
  const int out_of_range = ScatterLower(dim, nnz, irn, icn, a, dense);
  double max_abs = 0.0;
  const bool finite = LowerIsFinite(dim, dense, &max_abs);
  iw[0] = kMagic;
  iw[1] = dim;
  iw[2] = nnz;
  iw[3] = 0;
  int* ipiv = iw + kHeader;
  if (!finite) {
    info[0] = -5;  // cannot factorise NaN/Inf: report as singular so Ipopt perturbs / stops
    info[1] = 0;
    return;
  }

  int lapack_info = 0;
  double work_query = 0.0;
  const int lwork = 1;  // unblocked Bunch–Kaufman (dsytf2): best for the small dense systems here
  dsytrf_("L", &dim, dense, &dim, ipiv, &work_query, &lwork, &lapack_info, 1);
  if (lapack_info < 0) {
    info[0] = -6;  // an argument error inside LAPACK: cannot happen with the checks above
    info[1] = lapack_info;
    return;
  }

  const double tiny =
      std::max(cntl[2], static_cast<double>(dim) * std::numeric_limits<double>::epsilon() * max_abs);
  int negative = 0;
  int zero = 0;
  CountInertia(dim, dense, ipiv, tiny, &negative, &zero);
  info[14] = negative;  // INFO(15)
  info[11] = 0;         // INFO(12): real compressions
  info[12] = 0;         // INFO(13): integer compressions
  if (out_of_range > 0) {
    info[0] = 1;
    info[1] = out_of_range;
  }
  if (zero > 0 || lapack_info > 0) {
    info[0] = 3;  // rank deficient
    info[1] = dim - std::max(zero, 1);
    return;
  }
  iw[3] = 1;
}

void Ma27Cd(int* n, double* a, int* /*la*/, int* iw, int* /*liw*/, double* /*w*/, int* /*maxfrt*/,
            double* rhs, int* /*iw1*/, int* /*nsteps*/, int* /*icntl*/, double* /*cntl*/) {
  const int dim = *n;
  if (dim < 1 || iw[0] != kMagic || iw[1] != dim) return;  // no factor: leave RHS untouched
  const double* dense = a + iw[2];
  const int* ipiv = iw + kHeader;
  const int nrhs = 1;
  int lapack_info = 0;
  dsytrs_("L", &dim, &nrhs, dense, &dim, ipiv, rhs, &dim, &lapack_info, 1);
}

}  // namespace dense_ma27

namespace {
std::once_flag g_register_once;
}

void RegisterDenseMa27WithIpopt() {
  std::call_once(g_register_once, [] {
    LSL_setMA27(&dense_ma27::Ma27Ad, &dense_ma27::Ma27Bd, &dense_ma27::Ma27Cd,
                &dense_ma27::Ma27Id);
  });
}

}  // namespace quadtune::planning
