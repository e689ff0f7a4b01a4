#pragma once
/// \file
/// Reading configuration text safely: whole files with clear errors, UTF-8 checks, and a bounded
/// check of the YAML's shape before yaml-cpp builds any node. YamlMap::LoadFile and
/// YamlMap::FromString (quadtune/common/yaml.hpp), `--set` values and study overrides all pass
/// through it, so every YAML text quadtune reads is checked: not UTF-8, an alias, a key given
/// twice in one mapping, nesting, mappings, lists or a text past the limits below is a
/// ConfigError naming the file (and line or key). YamlMap::Integer reads decimal integers only
/// ("010" is ten; "0x10", "1e3" and "3.0" are errors), and YamlMap::String refuses text that is
/// not UTF-8.
///
/// Thread safety: free functions without shared state.

#include <cstddef>
#include <string>
#include <string_view>

namespace quadtune {

/// The whole content of a file. A missing file, a directory, a device, an unreadable file or one
/// past kMaxYamlBytes throws ConfigError(path, "", ...) saying which.
[[nodiscard]] std::string ReadFileText(const std::string& path);
/// Writes `text` to `path` through a temporary file beside it and a rename: a reader sees the
/// old file or the whole new one, never a part. Throws ConfigError(path, "", ...) naming the
/// system's reason (the temporary file is removed).
void WriteFileAtomically(const std::string& path, const std::string& text);
/// What keeps `path` from being read as a file ("cannot open the file: no such file", "is a
/// directory; expected a file", "is not a regular file"), or "" when it is a regular file.
[[nodiscard]] std::string FileProblem(const std::string& path);
/// Whether `path` names something that exists; false (never a throw) for a path the system
/// cannot even look up (a name too long, a file where a folder should be, no permission).
[[nodiscard]] bool PathExists(const std::string& path) noexcept;
/// True when `text` is well-formed UTF-8 (no overlong forms, surrogates or code points past
/// U+10FFFF).
[[nodiscard]] bool IsValidUtf8(std::string_view text);
/// Bytes of one YAML text (a file or a `--set` value): a saved layout at the 100 000-obstacle cap
/// is about 13 MB.
inline constexpr std::size_t kMaxYamlBytes = std::size_t{64} << 20;
/// Open mappings and lists around a value: quadtune files nest a few levels.
inline constexpr std::size_t kMaxYamlDepth = 64;
/// Keys of one mapping: the largest mapping a quadtune file holds has a few dozen keys.
inline constexpr std::size_t kMaxYamlMapKeys = 1000;
/// Entries of one list: the largest list is a saved layout's obstacles (at most 100 000).
inline constexpr std::size_t kMaxYamlListEntries = 100000;
/// Values (scalars, lists and mappings) of one text: a saved layout at the obstacle cap has
/// about 1.2 million; the limit bounds the memory yaml-cpp's nodes take.
inline constexpr std::size_t kMaxYamlNodes = 2000000;

/// Bounds of one YAML text past the fixed ones above: a reader that knows its file's size (a saved
/// layout) lowers the value count, so that an oversized file is refused before any node is built.
struct YamlBounds {
  std::size_t max_nodes = kMaxYamlNodes;
  std::string nodes_why = "the limit bounds the memory of reading";  ///< said in the refusal
};

/// Throws ConfigError(origin, dotted key path, ...) for the first of: an alias (`*name`; no
/// quadtune file uses anchors and aliases, so none is ever expanded), a key given twice in one
/// mapping (yaml-cpp keeps the first silently), a key that is not a plain name, or a text past
/// the limits above. Malformed YAML throws yaml-cpp's YAML::Exception (with its line), for the
/// caller to name. One pass over the parser's events
/// before any node is built: time linear in the text's bytes, memory bounded by the depth and
/// the keys of the open mappings. `key` prefixes every path (e.g. "--set budget.flights").
void CheckYamlShape(const std::string& text, const std::string& origin,
                    const std::string& key = "", const YamlBounds& bounds = {});
}  // namespace quadtune
