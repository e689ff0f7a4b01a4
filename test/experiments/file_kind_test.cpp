#include "file_kind.hpp"

#include <gtest/gtest.h>

#include <string>

#include "quadtune/common/error.hpp"

namespace quadtune::cli {
namespace {

const std::string kRoot = QUADTUNE_SOURCE_DIR;

TEST(FileKind, ShippedFilesAreToldApart) {
  EXPECT_EQ(DetectFileKind(kRoot + "/experiments/default.yaml"), FileKind::kExperiment);
  EXPECT_EQ(DetectFileKind(kRoot + "/experiments/benchmark_ego.yaml"), FileKind::kExperiment);
  EXPECT_EQ(DetectFileKind(kRoot + "/experiments/density_study.yaml"), FileKind::kStudy);
  EXPECT_EQ(DetectFileKind(kRoot + "/experiments/refinement_study.yaml"), FileKind::kStudy);
  EXPECT_EQ(DetectFileKind(kRoot + "/experiments/changing_environment.yaml"),
            FileKind::kAdaptation);
  EXPECT_EQ(DetectFileKind(kRoot + "/assets/drones/crazyflie.yaml"), FileKind::kDrone);
  EXPECT_EQ(DetectFileKind(kRoot + "/assets/layouts/forest_thin_1p3.yaml"), FileKind::kLayout);
  EXPECT_EQ(DetectFileKind(kRoot + "/no/such/file.yaml"), FileKind::kUnknown);
  EXPECT_EQ(DetectFileKind(kRoot + "/README.md"), FileKind::kUnknown);
}

TEST(FileKind, AnotherCommandsFileIsRefusedWithItsKindNamed) {
  const std::string run_file = kRoot + "/experiments/tiny.yaml";
  try {
    CheckFileKind(run_file, FileKind::kStudy);
    FAIL() << "a run file was accepted as a study file";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.file(), run_file);
    const std::string what = e.what();
    EXPECT_NE(what.find("this is an experiment file (for `quadtune run`"), std::string::npos)
        << what;
    EXPECT_NE(what.find("this command reads a study file"), std::string::npos) << what;
  }
  const std::string study_file = kRoot + "/experiments/density_study.yaml";
  try {
    CheckFileKind(study_file, FileKind::kExperiment);
    FAIL() << "a study file was accepted as an experiment file";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("this is a study file"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(CheckFileKind(run_file, FileKind::kExperiment));
  EXPECT_NO_THROW(CheckFileKind(kRoot + "/no/such/file.yaml", FileKind::kExperiment));
}

}  // namespace
}  // namespace quadtune::cli
