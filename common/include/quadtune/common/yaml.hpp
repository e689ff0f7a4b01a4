#pragma once
/// \file
/// Checked reading of YAML configuration. Every accessor names the file and the dotted key path
/// in its ConfigError, so a user learns exactly which value is wrong and what is allowed.
///
/// Thread safety: a YamlMap is a read-only view; concurrent reads of distinct YamlMaps are safe.

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "quadtune/common/error.hpp"
#include "quadtune/common/text_file.hpp"

namespace quadtune {

/// An allowed interval for a number, open or closed at either end.
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool lo_open = false;  ///< true: lo itself is not allowed
  bool hi_open = false;  ///< true: hi itself is not allowed

  [[nodiscard]] bool Contains(double v) const;
  /// Human-readable form, e.g. "a number in (0, inf)".
  [[nodiscard]] std::string Describe() const;

  static Range Any() { return {}; }
  static Range Positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
  static Range NonNegative() { return {0.0, std::numeric_limits<double>::infinity(), false, false}; }
  static Range Closed(double lo, double hi) { return {lo, hi, false, false}; }
  static Range OpenUnit() { return {0.0, 1.0, true, true}; }
};

/// Throws ConfigError(file, key, ...) unless `value` is finite and inside `range`.
void CheckInRange(double value, const Range& range, const std::string& file, const std::string& key);

/// A YAML mapping together with the file it came from and its key path inside that file.
class YamlMap {
 public:
  /// Parses a file; unreadable or malformed files, or files past the bounds (text_file.hpp),
  /// throw ConfigError naming the file (and line).
  static YamlMap LoadFile(const std::string& path, const YamlBounds& bounds = {});
  /// Parses text; `origin` stands in for the file name in error messages.
  static YamlMap FromString(const std::string& text, const std::string& origin = "<string>",
                            const YamlBounds& bounds = {});

  /// Wraps `node`, which must be a map (or null, read as empty).
  YamlMap(YAML::Node node, std::string file, std::string path = "");

  [[nodiscard]] bool Has(std::string_view key) const;
  [[nodiscard]] const std::string& file() const { return file_; }
  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] const YAML::Node& node() const { return node_; }
  /// Keys present in this map, in file order.
  [[nodiscard]] std::vector<std::string> Keys() const;
  /// Dotted path of `key` under this map, e.g. "drone.rotor.max_speed".
  [[nodiscard]] std::string KeyPath(std::string_view key) const;

  /// A number; absent → `fallback` (or an error when no fallback is given).
  [[nodiscard]] double Number(std::string_view key, std::optional<double> fallback = std::nullopt,
                              const Range& range = Range::Any()) const;
  /// An integer; absent → `fallback` (or an error).
  [[nodiscard]] long Integer(std::string_view key, std::optional<long> fallback = std::nullopt,
                             const Range& range = Range::Any()) const;
  [[nodiscard]] bool Bool(std::string_view key, std::optional<bool> fallback = std::nullopt) const;
  /// A string; when `allowed` is not empty the value must be one of them.
  [[nodiscard]] std::string String(std::string_view key,
                                   std::optional<std::string> fallback = std::nullopt,
                                   const std::vector<std::string>& allowed = {}) const;
  /// A sequence of exactly three numbers.
  [[nodiscard]] Eigen::Vector3d Vector3(std::string_view key,
                                        std::optional<Eigen::Vector3d> fallback = std::nullopt) const;
  /// A sequence of numbers of any length (exactly `size` when size >= 0).
  [[nodiscard]] std::vector<double> Numbers(std::string_view key, int size = -1) const;
  /// A nested map; absent → an empty map when `optional`, else an error.
  [[nodiscard]] YamlMap Map(std::string_view key, bool optional = false) const;
  /// A sequence of maps (absent → empty).
  [[nodiscard]] std::vector<YamlMap> Maps(std::string_view key) const;

  /// Throws ConfigError naming the first key not in `allowed` and listing what is allowed.
  void RejectUnknownKeys(std::initializer_list<std::string_view> allowed) const;
  void RejectUnknownKeys(const std::vector<std::string>& allowed) const;

  /// Throws ConfigError(file, KeyPath(key), message).
  [[noreturn]] void Fail(std::string_view key, const std::string& message) const;
  /// Fails at `key` unless `path` (the file `key` names, resolved) is a readable regular file:
  /// "file 'PATH' not found<where>", or "'PATH' is a directory; expected a file", ...
  void CheckFile(std::string_view key, const std::string& path, const std::string& where = "") const;

 private:
  [[nodiscard]] YAML::Node Lookup(std::string_view key) const;

  YAML::Node node_;
  std::string file_;
  std::string path_;
};

/// Configures an emitter so that doubles round-trip exactly (17 significant digits).
void SetExactDoubles(YAML::Emitter& out);

// ---- edits of YAML trees (studies, and `--set` on the command line) ----

/// `over` merged onto a copy of `base`: maps merge key by key, anything else replaces.
[[nodiscard]] YAML::Node YamlDeepMerge(const YAML::Node& base, const YAML::Node& over);
/// The node as YAML text.
[[nodiscard]] std::string YamlEmit(const YAML::Node& node);
/// Sets the dotted `path` (e.g. "budget.flights") of the map `root` to `value`, creating absent
/// parent maps. A parent that is not a map throws ConfigError(file, key, ...), as does an empty
/// part; `key` names the setting that asked for it (e.g. "sweep.key", "--set").
void YamlSetPath(YAML::Node root, const std::string& path, const YAML::Node& value,
                 const std::string& file, const std::string& key);
/// `text` (a YAML map, from `file`) with each "dotted.path=value" of `assignments` applied in
/// order; the value is read as YAML ("3", "[1, 2]", "{a: 1}", "layouts/x.yaml"). A malformed
/// assignment throws ConfigError(file, "--set", ...) naming it.
[[nodiscard]] std::string ApplyAssignments(const std::string& text,
                                           const std::vector<std::string>& assignments,
                                           const std::string& file);

}  // namespace quadtune
