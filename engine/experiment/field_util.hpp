#pragma once
/// \file
/// Helpers for the engine's field lists (common/fields.hpp): sections whose keys live in the
/// parent struct, and values written back as the configuration text gave them.
///
/// Thread safety: the functions are pure; the returned readers and writers may be called
/// concurrently.

#include <yaml-cpp/yaml.h>

#include <string>
#include <utility>

#include "quadtune/common/fields.hpp"

namespace quadtune::engine {

/// The reference row of a key holding a map.
inline FieldDoc MapDoc(std::string key, std::string meaning, std::string fallback = "") {
  return {std::move(key), "map", std::move(fallback), "", std::move(meaning)};
}

/// A reader of the map under `key` (absent: empty) by `sub`, into the same object: for sections
/// whose keys are members of the parent struct.
template <class T>
typename Fields<T>::Reader ReadSection(std::string key, const Fields<T>& sub) {
  return [key = std::move(key), &sub](const YamlMap& map, T& value) {
    sub.Read(map.Map(key, /*optional=*/true), value);
  };
}

/// The writer matching ReadSection.
template <class T>
typename Fields<T>::Writer WriteSection(std::string key, const Fields<T>& sub) {
  return [key = std::move(key), &sub](YAML::Emitter& out, const T& value) {
    out << YAML::Key << key << YAML::Value;
    sub.Write(out, value);
  };
}

/// Writes `key` of the YAML map `text` as it stands there (nothing when absent): for values
/// read by plug-ins whose settings are not kept as written (the planner plug-in).
inline void WriteAsGiven(YAML::Emitter& out, const std::string& text, const std::string& key) {
  if (text.empty()) return;
  const YAML::Node node = YAML::Load(text)[key];
  if (node) out << YAML::Key << key << YAML::Value << node;
}

}  // namespace quadtune::engine
