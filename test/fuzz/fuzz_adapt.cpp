// Fuzz target: the adaptation experiment reader (quadtune adapt) (see fuzz_util.hpp).
#include "fuzz_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/adaptation/online_adaptation.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = quadtune::fuzz::WriteInput(data, size, "adapt.yaml");
  try {
    (void)quadtune::engine::AdaptExperiment::LoadFile(path);
  } catch (const quadtune::ConfigError&) {
    // Bad input, reported as it should be.
  }
  return 0;
}
