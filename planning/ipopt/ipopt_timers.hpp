#pragma once
/// \file
/// The planning module's replacement of Ipopt's CPU-time clock (ipopt_timers.cpp says why).
/// Private to the module.

namespace quadtune::planning {

/// Does nothing. NewPlannerIpoptApplication() calls it so that every program that creates the
/// planner's Ipopt application links ipopt_timers.cpp out of the static planning library; the
/// definitions of Ipopt::CpuTime and Ipopt::SysTime there are referenced by no quadtune code
/// (libipopt calls them), so without this reference the linker would leave them out.
void LinkIpoptTimerOverride();

}  // namespace quadtune::planning
