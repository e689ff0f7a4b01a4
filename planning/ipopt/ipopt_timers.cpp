// Why this file exists: Ipopt times its internal tasks with Ipopt::CpuTime() and
// Ipopt::SysTime() (IpUtils), which in Ipopt 3.11.9 call getrusage(RUSAGE_SELF) at the start and
// end of every timed task: many system calls per iteration, each summing the CPU time of all
// threads of the process under a lock, a share of a single-threaded solve and contention
// between concurrent solves (docs/performance.md measures both). quadtune uses neither Ipopt's
// timing statistics nor its CPU-time limit (its options are deterministic: no max_cpu_time), so the
// definitions below take the place of libipopt's (libipopt calls them through the PLT, and a
// definition in the executable comes first) and read the vDSO monotonic clock instead (no
// system call). Effect: the "CPU" seconds Ipopt reports are elapsed seconds; no solve result
// depends on them.

#include "ipopt_timers.hpp"

#include <coin/IpUtils.hpp>
#include <ctime>

namespace quadtune::planning {

void LinkIpoptTimerOverride() {}

}  // namespace quadtune::planning

namespace Ipopt {

Number CpuTime() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<Number>(ts.tv_sec) + 1e-9 * static_cast<Number>(ts.tv_nsec);
}

Number SysTime() { return 0.0; }

}  // namespace Ipopt
