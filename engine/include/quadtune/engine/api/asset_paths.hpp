#pragma once
/// \file
/// Where the files an experiment names (drones, layouts) are found: next to the file, in the
/// working directory, then in the asset folders a program sets at start-up. Planner factories
/// (planner_registry.hpp) resolve their file names with ResolvePath and the `base_dir` they are
/// given.
///
/// Thread safety: SetAssetDirs must run before any other thread starts; AssetDirs and ResolvePath
/// may then be called from any thread.

#include <string>
#include <vector>

namespace quadtune::engine {

/// Sets the asset folders, searched in order by ResolvePath after the file's own folder and the
/// working directory. The library reads no environment and knows no folder of its own: a program
/// sets them once at start-up, before it loads a file or starts a thread (`quadtune`:
/// $QUADTUNE_ASSETS when set, then the source tree's assets/; a planner of one's own: the
/// installed package's assets, `quadtune_ASSETS_DIR`). Empty until set.
void SetAssetDirs(std::vector<std::string> dirs);
/// The asset folders SetAssetDirs set.
const std::vector<std::string>& AssetDirs();

/// Finds `relative`: as given when absolute, else under `base_dir`, under the working directory,
/// under each of AssetDirs(). Returns the first that exists (else `relative`).
std::string ResolvePath(const std::string& relative, const std::string& base_dir);

}  // namespace quadtune::engine
