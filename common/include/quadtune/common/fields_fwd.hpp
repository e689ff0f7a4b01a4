#pragma once
/// \file
/// Forward declarations of the configuration reader types, for headers that declare a
/// `FromYaml` or a field list without pulling in yaml-cpp (quadtune/common/yaml.hpp and
/// quadtune/common/fields.hpp hold the definitions).

namespace quadtune {
class YamlMap;
template <class T>
class Fields;
}  // namespace quadtune
