// Test programs find the drone and layout files that experiments name as `quadtune` does in the
// source tree: the source tree's assets/ is their asset folder (engine::SetAssetDirs), set while
// the program starts. Linked as an object (quadtune_test_assets) into every test program that
// links quadtune::engine.
#include "quadtune/engine/experiment/experiment.hpp"

namespace {

[[maybe_unused]] const bool kAssetDirsSet = [] {
  quadtune::engine::SetAssetDirs({QUADTUNE_SOURCE_DIR "/assets"});
  return true;
}();

}  // namespace
