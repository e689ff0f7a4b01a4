#pragma once
/// \file
/// Reading configuration text safely: whole files with clear errors, UTF-8 checks, and the
/// duplicate-key check that yaml-cpp lacks. YamlMap::LoadFile and YamlMap::FromString
/// (quadtune/common/yaml.hpp) use all three, so every YAML file quadtune reads is checked:
/// not UTF-8, nesting past yaml-cpp's depth limit, or a key given twice in one mapping is a
/// ConfigError naming the file (and line or key). YamlMap::Integer reads decimal integers only
/// ("010" is ten; "0x10", "1e3" and "3.0" are errors), and YamlMap::String refuses text that is
/// not UTF-8.
///
/// Thread safety: free functions without shared state.

#include <yaml-cpp/yaml.h>

#include <string>
#include <string_view>

namespace quadtune {

/// The whole content of a file. A missing file, a directory, a device or an unreadable file
/// throws ConfigError(path, "", ...) saying which.
[[nodiscard]] std::string ReadFileText(const std::string& path);
/// Whether `path` names something that exists; false (never a throw) for a path the system
/// cannot even look up (a name too long, a file where a folder should be, no permission).
[[nodiscard]] bool PathExists(const std::string& path) noexcept;
/// True when `text` is well-formed UTF-8 (no overlong forms, surrogates or code points past
/// U+10FFFF).
[[nodiscard]] bool IsValidUtf8(std::string_view text);
/// Throws ConfigError(origin, dotted key path, ...) for the first mapping in `root` that holds
/// one key twice (yaml-cpp keeps the first silently).
void RejectDuplicateKeys(const YAML::Node& root, const std::string& origin);

}  // namespace quadtune
