// MpiLaunchSize: how `quadtune run` tells that an MPI launcher started it (the seam through which
// a build without MPI refuses a multi-process launch; cli_paths_tests checks the refusal itself
// in such a build).
#include <gtest/gtest.h>

#include <cstdlib>

#include "quadtune/engine/distributed.hpp"

namespace quadtune::engine {
namespace {

// Clears the launchers' variables for the test's duration and restores none (tests run in their
// own process under ctest).
void ClearLauncherEnvironment() {
  for (const char* v :
       {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_STEP_NUM_TASKS", "SLURM_PROCID"}) {
    unsetenv(v);
  }
}

TEST(MpiLaunchSize, OneWithoutALauncher) {
  ClearLauncherEnvironment();
  EXPECT_EQ(MpiLaunchSize(), 1);
}

TEST(MpiLaunchSize, ReadsOpenMpiMpichAndSlurm) {
  ClearLauncherEnvironment();
  setenv("OMPI_COMM_WORLD_SIZE", "4", 1);
  EXPECT_EQ(MpiLaunchSize(), 4);
  ClearLauncherEnvironment();
  setenv("PMI_SIZE", "3", 1);
  EXPECT_EQ(MpiLaunchSize(), 3);
  ClearLauncherEnvironment();
  // srun: the task count counts only with a process id (an srun step, not an sbatch shell).
  setenv("SLURM_STEP_NUM_TASKS", "6", 1);
  EXPECT_EQ(MpiLaunchSize(), 1);
  setenv("SLURM_PROCID", "0", 1);
  EXPECT_EQ(MpiLaunchSize(), 6);
  ClearLauncherEnvironment();
}

}  // namespace
}  // namespace quadtune::engine
