#include "file_kind.hpp"

#include <yaml-cpp/yaml.h>

#include <initializer_list>

#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::cli {
namespace {

bool HasAny(const YAML::Node& top, std::initializer_list<const char*> keys) {
  for (const char* key : keys) {
    if (top[key]) return true;
  }
  return false;
}

}  // namespace

std::string Describe(FileKind kind) {
  switch (kind) {
    case FileKind::kExperiment:
      return "an experiment file (for `quadtune run`, `sweep` or `bench`)";
    case FileKind::kStudy:
      return "a study file (for `quadtune study`)";
    case FileKind::kAdaptation:
      return "an adaptation file (for `quadtune adapt`)";
    case FileKind::kDrone:
      return "a drone description (for planner.drone or `quadtune fly --drone`)";
    case FileKind::kLayout:
      return "layout options (for planner.layout_file or `quadtune layout --layout-options`)";
    case FileKind::kUnknown:
      break;
  }
  return "a file of unknown kind";
}

FileKind DetectFileKind(const std::string& path) {
  // Through the checked reader (directories, bad UTF-8, duplicate keys and deep nesting refused
  // before yaml-cpp sees the bytes); whatever it refuses, the command's own reader reports.
  YAML::Node top;
  try {
    top = YamlMap::LoadFile(path).node();
  } catch (const ConfigError&) {
    return FileKind::kUnknown;
  }
  if (!top.IsMap()) return FileKind::kUnknown;
  if (HasAny(top, {"experiment", "override", "sweep", "stages"})) return FileKind::kStudy;
  if (HasAny(top, {"adaptation", "baselines"})) return FileKind::kAdaptation;
  if (top["mass"] && top["inertia"]) return FileKind::kDrone;
  if (HasAny(top, {"methods", "budget", "short_term", "long_term"})) return FileKind::kExperiment;
  if (!top["planner"] && HasAny(top, {"region", "spacing", "obstacles"})) return FileKind::kLayout;
  return FileKind::kUnknown;
}

void CheckFileKind(const std::string& path, FileKind expected) {
  const FileKind kind = DetectFileKind(path);
  if (kind == FileKind::kUnknown || kind == expected) return;
  throw ConfigError(path, "",
                    "this is " + Describe(kind) + ", but this command reads " + Describe(expected));
}

}  // namespace quadtune::cli
