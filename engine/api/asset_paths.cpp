#include "quadtune/engine/api/asset_paths.hpp"

#include <filesystem>
#include <utility>

#include "quadtune/common/text_file.hpp"

namespace quadtune::engine {
namespace {

std::vector<std::string>& AssetDirList() {
  static std::vector<std::string> dirs;
  return dirs;
}

}  // namespace

void SetAssetDirs(std::vector<std::string> dirs) { AssetDirList() = std::move(dirs); }

const std::vector<std::string>& AssetDirs() { return AssetDirList(); }

std::string ResolvePath(const std::string& relative, const std::string& base_dir) {
  namespace fs = std::filesystem;
  if (relative.empty() || fs::path(relative).is_absolute()) return relative;
  std::vector<fs::path> candidates{fs::path(base_dir) / relative, fs::path(relative)};
  for (const std::string& dir : AssetDirs()) candidates.push_back(fs::path(dir) / relative);
  for (const auto& c : candidates) {
    if (PathExists(c.string())) return c.string();
  }
  return relative;
}

}  // namespace quadtune::engine
