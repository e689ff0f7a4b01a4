#pragma once
/// \file
/// The Ipopt application the planner's solves run in (TrajectoryOptimizer keeps one per thread).
///
/// Options (all deterministic; no CPU or wall-time limit): print level 0 and no banner, no
/// option file, `linear_solver ma27` backed by the thread-safe dense solver of dense_ma27.hpp
/// (registered here), no linear-system scaling, the exact Hessian, `max_soc 0` (without
/// constraints second-order corrections only cost evaluations), `tiny_step_tol 1e-8` (a step
/// below that relative size is taken without a line search, which cannot resolve it; see
/// NewPlannerIpoptApplication's definition). The per-solve options (`tol`,
/// `max_iter`, the "acceptable" stall test) are set by TrajectoryOptimizer::Solve.
///
/// UnconstrainedDenseTnlp is the part every such problem shares (the planner's MinJerkProblem
/// and the benchmark's test function): n free variables, no constraints, a dense Hessian.
///
/// Requires Ipopt's headers (the planning module links Ipopt privately; a target including this
/// file links PkgConfig::IPOPT itself).

#include <coin/IpIpoptApplication.hpp>
#include <coin/IpTNLP.hpp>

namespace quadtune::planning {

/// A new, initialised application with the planner's options. Creating one has a cost of its own
/// (docs/performance.md: `ipopt_floor_bench --benchmark_filter=NewApplication`); reuse it for
/// many solves (one thread at a time).
Ipopt::SmartPtr<Ipopt::IpoptApplication> NewPlannerIpoptApplication();

/// Base of an unconstrained problem in n unbounded variables whose Hessian is handed to Ipopt as
/// its full lower triangle, row by row (C-style indices). Supplies the problem size, the (absent)
/// bounds and constraints; subclasses supply the starting point, f, ∇f, the Hessian values (in
/// the order of DenseLowerStructure) and finalize_solution.
class UnconstrainedDenseTnlp : public Ipopt::TNLP {
 public:
  explicit UnconstrainedDenseTnlp(Ipopt::Index n) : n_(n) {}

  bool get_nlp_info(Ipopt::Index& n, Ipopt::Index& m, Ipopt::Index& nnz_jac_g,
                    Ipopt::Index& nnz_h_lag, IndexStyleEnum& index_style) final {
    n = n_;
    m = 0;
    nnz_jac_g = 0;
    nnz_h_lag = n_ * (n_ + 1) / 2;
    index_style = C_STYLE;
    return true;
  }
  bool get_bounds_info(Ipopt::Index n, Ipopt::Number* x_l, Ipopt::Number* x_u, Ipopt::Index /*m*/,
                       Ipopt::Number* /*g_l*/, Ipopt::Number* /*g_u*/) final {
    for (Ipopt::Index i = 0; i < n; ++i) {
      x_l[i] = -1e20;  // below nlp_lower_bound_inf: unbounded
      x_u[i] = 1e20;
    }
    return true;
  }
  bool eval_g(Ipopt::Index /*n*/, const Ipopt::Number* /*x*/, bool /*new_x*/, Ipopt::Index /*m*/,
              Ipopt::Number* /*g*/) final {
    return true;
  }
  bool eval_jac_g(Ipopt::Index /*n*/, const Ipopt::Number* /*x*/, bool /*new_x*/,
                  Ipopt::Index /*m*/, Ipopt::Index /*nele_jac*/, Ipopt::Index* /*iRow*/,
                  Ipopt::Index* /*jCol*/, Ipopt::Number* /*values*/) final {
    return true;
  }

  /// The Hessian structure eval_h reports when called with values == nullptr: (r, c) for
  /// r = 0…n−1, c = 0…r.
  static void DenseLowerStructure(Ipopt::Index n, Ipopt::Index* iRow, Ipopt::Index* jCol) {
    Ipopt::Index k = 0;
    for (Ipopt::Index r = 0; r < n; ++r) {
      for (Ipopt::Index c = 0; c <= r; ++c, ++k) {
        iRow[k] = r;
        jCol[k] = c;
      }
    }
  }

 protected:
  Ipopt::Index n_;  ///< number of variables
};

}  // namespace quadtune::planning
