#pragma once
/// \file
/// A thread-safe, MA27-compatible dense symmetric-indefinite linear solver for Ipopt.
///
/// Debian's Ipopt 3.11.9 ships only sequential MUMPS, which crashes when two threads solve at once
/// (docs/design.md, "Concurrent Ipopt solves"). Ipopt can instead call an MA27-interface solver
/// registered in-process with `LSL_setMA27` and selected with the option `linear_solver ma27`.
/// This file supplies such a solver: the four MA27 entry points (MA27ID/AD/BD/CD, same
/// Fortran-style signatures as in <coin/HSLLoader.h>) implemented on LAPACK's Bunch–Kaufman
/// factorisation (dsytrf/dsytrs).
///
/// Every bit of state lives in the arrays the caller passes (A, IW, INFO, ...): the entry points
/// keep no static or global data, so concurrent solves in different threads (each with its own
/// Ipopt application and therefore its own arrays) never share state.
///
/// Semantics the Ipopt MA27 interface relies on (Ipopt's Ma27TSolverInterface):
///  - MA27AD (analysis): INFO(1) = 0 on success, INFO(5) = real workspace LA needed by MA27BD,
///    INFO(6) = integer workspace LIW needed; NSTEPS is set (here 1). Entries out of range are
///    counted in INFO(2) and flagged with INFO(1) = 1 (as MA27 does); Ipopt treats that as fatal.
///  - MA27BD (factorisation): the first NZ entries of A hold the matrix values (triplets IRN/ICN,
///    1-based, either triangle, duplicates summed). On return INFO(1) = 0 (regular), 3 (singular:
///    INFO(2) = numerical rank), -3 (LIW too small, INFO(2) = LIW needed), -4 (LA too small,
///    INFO(2) = LA needed), -1/-2 (bad N/NZ); INFO(15) = number of negative eigenvalues (inertia,
///    from the 1×1 and 2×2 blocks of D); INFO(12), INFO(13) = 0 compressions; MAXFRT = N.
///    The dense factor is stored in A after the input values and the pivots in IW.
///  - MA27CD (solve): overwrites RHS with the solution, reading only A and IW.
/// A pivot is treated as zero (singular matrix) when |pivot| <= max(CNTL(3), n·ε·max|a_ij|)
/// (for 2×2 blocks: |det| <= that threshold times the block's largest entry).
///
/// Thread safety: all functions are reentrant; the one-time registration is guarded by
/// std::call_once.

namespace quadtune::planning {

/// Registers the dense MA27 implementation with Ipopt's HSL loader (LSL_setMA27). Idempotent and
/// thread-safe (std::call_once); call before the first Ipopt solve that uses `linear_solver ma27`.
void RegisterDenseMa27WithIpopt();

namespace dense_ma27 {

/// MA27ID: default control parameters. ICNTL has 30 entries, CNTL 5.
void Ma27Id(int* icntl, double* cntl);

/// MA27AD: analysis (Fortran signature; every argument by pointer, indices 1-based).
void Ma27Ad(int* n, int* nz, const int* irn, const int* icn, int* iw, int* liw, int* ikeep,
            int* iw1, int* nsteps, int* iflag, int* icntl, double* cntl, int* info, double* ops);

/// MA27BD: numerical factorisation; A's first NZ entries are the values of (IRN, ICN).
void Ma27Bd(int* n, int* nz, const int* irn, const int* icn, double* a, int* la, int* iw,
            int* liw, int* ikeep, int* nsteps, int* maxfrt, int* iw1, int* icntl, double* cntl,
            int* info);

/// MA27CD: solve with the factor left in A/IW by Ma27Bd; RHS (length N) becomes the solution.
void Ma27Cd(int* n, double* a, int* la, int* iw, int* liw, double* w, int* maxfrt, double* rhs,
            int* iw1, int* nsteps, int* icntl, double* cntl);

}  // namespace dense_ma27
}  // namespace quadtune::planning
