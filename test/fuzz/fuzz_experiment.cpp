// Fuzz target: the experiment reader (quadtune run) (see fuzz_util.hpp).
#include "fuzz_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/experiment/experiment.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = quadtune::fuzz::WriteInput(data, size, "experiment.yaml");
  try {
    (void)quadtune::engine::Experiment::LoadFile(path);
  } catch (const quadtune::ConfigError&) {
    // Bad input, reported as it should be.
  }
  return 0;
}
