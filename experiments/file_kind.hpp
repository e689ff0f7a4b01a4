#pragma once
/// Which kind of quadtune input a YAML file is, told from its top-level keys, so that a command
/// given another command's file says what the file is instead of listing unknown keys.
///
/// Reads the file; no other side effects. Thread safety: none needed.

#include <array>
#include <string>

#include "quadtune/common/enum_names.hpp"

namespace quadtune::cli {

enum class FileKind { kExperiment, kStudy, kAdaptation, kDrone, kLayout, kUnknown };
constexpr auto EnumNames(FileKind) {
  return std::array{
      EnumName{FileKind::kExperiment, "experiment"}, EnumName{FileKind::kStudy, "study"},
      EnumName{FileKind::kAdaptation, "adaptation"}, EnumName{FileKind::kDrone, "drone"},
      EnumName{FileKind::kLayout, "layout"},         EnumName{FileKind::kUnknown, "unknown"}};
}

/// "experiment file (for `quadtune run`)", "study file (for `quadtune study`)", …
[[nodiscard]] std::string Describe(FileKind kind);

/// The kind of the YAML file at `path` from its top-level keys: a study names `experiment`,
/// `override`, `sweep` or `stages`; an adaptation file `adaptation` or `baselines`; a drone
/// `mass` and `inertia`; an experiment `methods`, `budget`, `short_term` or `long_term`; layout
/// options `region`, `spacing` or `obstacles`. kUnknown when the file cannot be read or parsed
/// or is not a map (the command's own reader then reports why).
[[nodiscard]] FileKind DetectFileKind(const std::string& path);

/// Throws ConfigError naming `path`, what kind of file it is and which command reads it, when
/// the file is of a known kind other than `expected`; returns otherwise.
void CheckFileKind(const std::string& path, FileKind expected);

}  // namespace quadtune::cli
