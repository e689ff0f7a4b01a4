// MpiLaunchSize: how `quadtune run` tells that an MPI launcher started it; CheckMpiLaunch: the
// refusal of a multi-process launch by a build without MPI, tested here in every build
// (cli_paths_tests checks the program's exit code and message in a build without MPI).
#include <gtest/gtest.h>

#include <cstdlib>

#include "../config_error_util.hpp"
#include "quadtune/engine/distributed/distributed.hpp"

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

TEST(CheckMpiLaunch, BuildWithoutMpiRefusesSeveralProcesses) {
  EXPECT_TRUE(quadtune::test::ThrowsConfigError([] { CheckMpiLaunch(2, /*mpi_built=*/false); },
                                                "mpirun",
                                                {"one of 2 MPI processes", "built without MPI"}));
  EXPECT_TRUE(quadtune::test::ThrowsConfigError([] { CheckMpiLaunch(16, /*mpi_built=*/false); },
                                                "mpirun", {"one of 16 MPI processes"}));
}

TEST(CheckMpiLaunch, OneProcessOrAnMpiBuildIsAccepted) {
  EXPECT_NO_THROW(CheckMpiLaunch(1, /*mpi_built=*/false));
  EXPECT_NO_THROW(CheckMpiLaunch(1, /*mpi_built=*/true));
  EXPECT_NO_THROW(CheckMpiLaunch(4, /*mpi_built=*/true));
}

TEST(CheckSingleProcessLaunch, SeveralProcessesAreRefusedWithTheCommandNamed) {
  EXPECT_TRUE(quadtune::test::ThrowsConfigError(
      [] { CheckSingleProcessLaunch(2, "study"); }, "mpirun",
      {"`quadtune study` runs in one process", "one of 2 MPI processes", "only `quadtune run`"}));
  EXPECT_TRUE(quadtune::test::ThrowsConfigError([] { CheckSingleProcessLaunch(8, "adapt"); },
                                                "mpirun", {"`quadtune adapt`", "one of 8"}));
  EXPECT_NO_THROW(CheckSingleProcessLaunch(1, "sweep"));
}

}  // namespace
}  // namespace quadtune::engine
