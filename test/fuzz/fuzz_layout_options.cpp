// Fuzz target: the layout generator options reader (see fuzz_util.hpp).
#include "fuzz_util.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/layout/options.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = quadtune::fuzz::WriteInput(data, size, "layout_options.yaml");
  try {
    (void)quadtune::layout::LayoutOptions::LoadFile(path);
  } catch (const quadtune::ConfigError&) {
    // Bad input, reported as it should be.
  }
  return 0;
}
