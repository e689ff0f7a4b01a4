// Fuzz target: the saved layout reader (fly --layout) (see fuzz_util.hpp).
#include "fuzz_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/layout/layout.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = quadtune::fuzz::WriteInput(data, size, "saved_layout.yaml");
  try {
    (void)quadtune::layout::Layout::Load(path);
  } catch (const quadtune::ConfigError&) {
    // Bad input, reported as it should be.
  }
  return 0;
}
