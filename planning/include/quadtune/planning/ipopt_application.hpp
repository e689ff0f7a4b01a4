#pragma once
/// \file
/// The Ipopt application the planner's solves run in (TrajectoryOptimizer keeps one per thread).
///
/// Options (all deterministic; no CPU or wall-time limit): print level 0 and no banner, no
/// option file, `linear_solver ma27` backed by the thread-safe dense solver of dense_ma27.hpp
/// (registered here), no linear-system scaling, the exact Hessian, `max_soc 0` (without
/// constraints second-order corrections only cost evaluations). The per-solve options (`tol`,
/// `max_iter`, the "acceptable" stall test) are set by TrajectoryOptimizer::Solve.
///
/// Requires Ipopt's headers (the planning module links Ipopt privately; a target including this
/// file links PkgConfig::IPOPT itself).

#include <coin/IpIpoptApplication.hpp>

namespace quadtune::planning {

/// A new, initialised application with the planner's options. Creating one costs ≈0.3 ms;
/// reuse it for many solves (one thread at a time).
Ipopt::SmartPtr<Ipopt::IpoptApplication> NewPlannerIpoptApplication();

}  // namespace quadtune::planning
