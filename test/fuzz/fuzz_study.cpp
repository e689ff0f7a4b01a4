// Fuzz target: the study reader (quadtune study) (see fuzz_util.hpp).
#include "fuzz_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/tuning/study.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // The corpus names the toy experiment (test/support/toy.yaml) by its file name.
  static const bool asset_dirs_set = [] {
    quadtune::engine::SetAssetDirs(
        {QUADTUNE_SOURCE_DIR "/test/support", QUADTUNE_SOURCE_DIR "/assets"});
    return true;
  }();
  (void)asset_dirs_set;
  const std::string path = quadtune::fuzz::WriteInput(data, size, "study.yaml");
  try {
    (void)quadtune::engine::Study::LoadFile(path);
  } catch (const quadtune::ConfigError&) {
    // Bad input, reported as it should be.
  }
  return 0;
}
