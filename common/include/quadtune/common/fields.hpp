#pragma once
/// \file
/// Field lists: one list per options struct says, for every key, its member, type, range and
/// meaning. The list reads the struct from YAML (unknown keys refused, every value checked
/// with an error naming file and key), writes it back, and documents it: the configuration
/// reference (docs/config.md, `quadtune config-reference`) is generated from the same lists, so
/// the keys a reader accepts and the keys the reference describes cannot drift apart.
///
/// ```
/// const Fields<PsoOptions>& PsoFields() {
///   static const Fields<PsoOptions> fields = Fields<PsoOptions>()
///       .Integer("num_particles", &PsoOptions::num_particles, Range::Closed(1, 1e6),
///                "swarm size")
///       .Number("inertia", &PsoOptions::inertia, Range::Closed(0, 1.5), "inertia weight w")
///       .Choice("bound_handling", &PsoOptions::bound_handling, "what a particle leaving ...");
///   return fields;
/// }
/// PsoOptions PsoOptions::FromYaml(const YamlMap& map) { return PsoFields().Read(map); }
/// ```
///
/// Reading starts from the values already in the struct (a default-constructed one, or
/// inherited values), so an absent key keeps them; `Required()` makes the last field's key
/// mandatory. Fields are read in list order, which fixes which of several bad values is
/// reported. A custom field (`Custom`) brings its own reader, writer and reference row, for
/// values that are not a plain key (lists of maps, maps of names, values read in two keys).
///
/// Thread safety: a Fields object is immutable once built; concurrent reads are safe.

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune {

/// One row of the configuration reference.
struct FieldDoc {
  std::string key;
  std::string type;      ///< "number", "integer", "bool", "string", "[x, y, z]", "map", ...
  std::string fallback;  ///< the default as text; "required" when the key must be given
  std::string allowed;   ///< e.g. "(0, inf)" or "`reflect`, `clamp`"; empty when anything goes
  std::string meaning;
};

/// `v` as the reference shows it: the shortest text that reads back as `v`.
[[nodiscard]] std::string FormatNumber(double v);
/// The interval part of Range::Describe ("(0, inf)"); empty for Range::Any().
[[nodiscard]] std::string DescribeInterval(const Range& range);
/// `names` as "`a`, `b`, `c`".
[[nodiscard]] std::string CodeList(const std::vector<std::string>& names);
/// `rows` as a Markdown table with the columns key, type, default, allowed, meaning.
[[nodiscard]] std::string MarkdownTable(const std::vector<FieldDoc>& rows);

/// An enum read as one of its names (enum_names.hpp); absent → `fallback`.
template <NamedEnum E>
[[nodiscard]] E ReadEnum(const YamlMap& map, std::string_view key, std::optional<E> fallback) {
  const std::optional<std::string> text =
      fallback ? std::optional<std::string>(ToString(*fallback)) : std::nullopt;
  return *FromString<E>(map.String(key, text, EnumNameList<E>()));
}

template <class T>
class Fields {
 public:
  using Reader = std::function<void(const YamlMap&, T&)>;
  using Writer = std::function<void(YAML::Emitter&, const T&)>;

  /// A floating-point member checked against `range`.
  Fields& Number(std::string key, double T::*member, Range range, std::string meaning) {
    auto& f = Add(std::move(key), "number", DescribeInterval(range), std::move(meaning));
    f.read = [k = f.doc.key, member, range](const YamlMap& m, T& t, bool required) {
      t.*member = m.Number(k, required ? std::nullopt : std::optional<double>(t.*member), range);
    };
    f.write = [k = f.doc.key, member](YAML::Emitter& out, const T& t) {
      out << YAML::Key << k << YAML::Value << t.*member;
    };
    f.show = [member](const T& t) { return FormatNumber(t.*member); };
    f.check = [k = f.doc.key, member, range](const T& t, const std::string& file,
                                             const std::string& prefix) {
      CheckInRange(t.*member, range, file, prefix + k);
    };
    return *this;
  }

  /// An optional floating-point member: absent keys leave it empty.
  Fields& OptionalNumber(std::string key, std::optional<double> T::*member, Range range,
                         std::string meaning) {
    auto& f = Add(std::move(key), "number", DescribeInterval(range), std::move(meaning));
    f.read = [k = f.doc.key, member, range](const YamlMap& m, T& t, bool) {
      if (m.Has(k)) t.*member = m.Number(k, std::nullopt, range);
    };
    f.write = [k = f.doc.key, member](YAML::Emitter& out, const T& t) {
      if (t.*member) out << YAML::Key << k << YAML::Value << *(t.*member);
    };
    f.show = [member](const T& t) { return t.*member ? FormatNumber(*(t.*member)) : "absent"; };
    f.check = [k = f.doc.key, member, range](const T& t, const std::string& file,
                                             const std::string& prefix) {
      if (t.*member) CheckInRange(*(t.*member), range, file, prefix + k);
    };
    return *this;
  }

  /// An integer member (int, long, std::uint64_t, ...) checked against `range`.
  template <class I>
    requires std::is_integral_v<I> && (!std::is_same_v<I, bool>)
  Fields& Integer(std::string key, I T::*member, Range range, std::string meaning) {
    auto& f = Add(std::move(key), "integer", DescribeInterval(range), std::move(meaning));
    f.read = [k = f.doc.key, member, range](const YamlMap& m, T& t, bool required) {
      const auto current = static_cast<long>(t.*member);
      t.*member = static_cast<I>(
          m.Integer(k, required ? std::nullopt : std::optional<long>(current), range));
    };
    f.write = [k = f.doc.key, member](YAML::Emitter& out, const T& t) {
      out << YAML::Key << k << YAML::Value << t.*member;
    };
    f.show = [member](const T& t) { return std::to_string(t.*member); };
    f.check = [k = f.doc.key, member, range](const T& t, const std::string& file,
                                             const std::string& prefix) {
      if (!range.Contains(static_cast<double>(t.*member))) {
        throw ConfigError(file, prefix + k,
                          "got " + std::to_string(t.*member) + ", allowed: an integer in " +
                              DescribeInterval(range));
      }
    };
    return *this;
  }

  Fields& Flag(std::string key, bool T::*member, std::string meaning) {
    auto& f = Add(std::move(key), "bool", "", std::move(meaning));
    f.read = [k = f.doc.key, member](const YamlMap& m, T& t, bool required) {
      t.*member = m.Bool(k, required ? std::nullopt : std::optional<bool>(t.*member));
    };
    f.write = [k = f.doc.key, member](YAML::Emitter& out, const T& t) {
      out << YAML::Key << k << YAML::Value << t.*member;
    };
    f.show = [member](const T& t) { return std::string(t.*member ? "true" : "false"); };
    return *this;
  }

  /// A string member; when `allowed` is not empty the value must be one of them.
  Fields& Text(std::string key, std::string T::*member, std::vector<std::string> allowed,
               std::string meaning) {
    auto& f = Add(std::move(key), "string", CodeList(allowed), std::move(meaning));
    f.read = [k = f.doc.key, member, allowed = std::move(allowed)](const YamlMap& m, T& t,
                                                                     bool required) {
      t.*member =
          m.String(k, required ? std::nullopt : std::optional<std::string>(t.*member), allowed);
    };
    f.write = [k = f.doc.key, member](YAML::Emitter& out, const T& t) {
      out << YAML::Key << k << YAML::Value << t.*member;
    };
    f.show = [member](const T& t) { return (t.*member).empty() ? "\"\"" : "`" + t.*member + "`"; };
    return *this;
  }

  /// An enum member, spelled by its name table (enum_names.hpp).
  template <NamedEnum E>
  Fields& Choice(std::string key, E T::*member, std::string meaning) {
    auto& f = Add(std::move(key), "string", CodeList(EnumNameList<E>()), std::move(meaning));
    f.read = [k = f.doc.key, member](const YamlMap& m, T& t, bool required) {
      t.*member = ReadEnum<E>(m, k, required ? std::nullopt : std::optional<E>(t.*member));
    };
    f.write = [k = f.doc.key, member](YAML::Emitter& out, const T& t) {
      out << YAML::Key << k << YAML::Value << ToString(t.*member);
    };
    f.show = [member](const T& t) { return "`" + std::string(ToString(t.*member)) + "`"; };
    return *this;
  }

  /// A three-vector member, written [x, y, z].
  Fields& Vector3(std::string key, Eigen::Vector3d T::*member, std::string meaning) {
    auto& f = Add(std::move(key), "[x, y, z]", "", std::move(meaning));
    f.read = [k = f.doc.key, member](const YamlMap& m, T& t, bool required) {
      t.*member = m.Vector3(k, required ? std::nullopt
                                          : std::optional<Eigen::Vector3d>(t.*member));
    };
    f.write = [k = f.doc.key, member](YAML::Emitter& out, const T& t) {
      const Eigen::Vector3d& v = t.*member;
      out << YAML::Key << k << YAML::Value << YAML::Flow << YAML::BeginSeq << v.x() << v.y()
          << v.z() << YAML::EndSeq;
    };
    f.show = [member](const T& t) {
      const Eigen::Vector3d& v = t.*member;
      return "[" + FormatNumber(v.x()) + ", " + FormatNumber(v.y()) + ", " +
             FormatNumber(v.z()) + "]";
    };
    return *this;
  }

  /// A nested map read by its own field list; absent → the member keeps its values. `sub` must
  /// outlive this list (a function-local static). The reference documents `sub` in a section
  /// of its own, which `meaning` names.
  template <class S>
  Fields& Nested(std::string key, S T::*member, const Fields<S>& sub, std::string meaning) {
    auto& f = Add(std::move(key), "map", "", std::move(meaning));
    f.read = [k = f.doc.key, member, &sub](const YamlMap& m, T& t, bool required) {
      sub.Read(m.Map(k, /*optional=*/!required), t.*member);
    };
    f.write = [k = f.doc.key, member, &sub](YAML::Emitter& out, const T& t) {
      out << YAML::Key << k << YAML::Value;
      sub.Write(out, t.*member);
    };
    f.show = [](const T&) { return std::string("see below"); };
    f.check = [k = f.doc.key, member, &sub](const T& t, const std::string& file,
                                            const std::string& prefix) {
      sub.Check(t.*member, file, prefix + k + ".");
    };
    return *this;
  }

  /// A key with its own reader and writer; `doc` gives its reference row as it stands (its
  /// `key` names the field).
  Fields& Custom(FieldDoc doc, Reader read, Writer write) {
    auto& f = Add(doc.key, doc.type, doc.allowed, doc.meaning);
    const std::string fallback = doc.fallback;
    f.read = [read = std::move(read)](const YamlMap& m, T& t, bool) { read(m, t); };
    f.write = std::move(write);
    f.show = [fallback](const T&) { return fallback; };
    return *this;
  }

  /// The last field's key must be given (reference default: "required").
  Fields& Required() {
    fields_.back().required = true;
    return *this;
  }

  /// Checks every key of `map` against the list, then reads the fields in list order into
  /// `into`; absent keys keep `into`'s values.
  void Read(const YamlMap& map, T& into) const {
    map.RejectUnknownKeys(Keys());
    for (const Field& f : fields_) f.read(map, into, f.required);
  }
  /// Read into a default-constructed T.
  [[nodiscard]] T Read(const YamlMap& map) const {
    T value{};
    Read(map, value);
    return value;
  }

  /// Throws ConfigError(file, prefix + key, ...) for the first number or integer outside its
  /// range (nested lists included), in list order: the checks Read makes, for a value built in
  /// code.
  void Check(const T& value, const std::string& file = "", const std::string& prefix = "") const {
    for (const Field& f : fields_) {
      if (f.check) f.check(value, file, prefix);
    }
  }

  /// Writes `value` as one YAML map, every field in list order.
  void Write(YAML::Emitter& out, const T& value) const {
    out << YAML::BeginMap;
    for (const Field& f : fields_) f.write(out, value);
    out << YAML::EndMap;
  }

  /// The keys, in list order.
  [[nodiscard]] std::vector<std::string> Keys() const {
    std::vector<std::string> keys;
    keys.reserve(fields_.size());
    for (const Field& f : fields_) keys.push_back(f.doc.key);
    return keys;
  }

  /// The reference rows, defaults taken from `defaults`.
  [[nodiscard]] std::vector<FieldDoc> Docs(const T& defaults = T{}) const {
    std::vector<FieldDoc> rows;
    for (const Field& f : fields_) {
      FieldDoc row = f.doc;
      row.fallback = f.required ? "required" : f.show(defaults);
      rows.push_back(std::move(row));
    }
    return rows;
  }

 private:
  struct Field {
    FieldDoc doc;
    bool required = false;
    std::function<void(const YamlMap&, T&, bool required)> read;
    Writer write;
    std::function<std::string(const T&)> show;
    std::function<void(const T&, const std::string& file, const std::string& prefix)> check;
  };

  Field& Add(std::string key, std::string type, std::string allowed, std::string meaning) {
    for (const Field& f : fields_) QT_DEMAND(f.doc.key != key, "key '" + key + "' listed twice");
    fields_.push_back(Field{{std::move(key), std::move(type), "", std::move(allowed),
                             std::move(meaning)},
                            false, {}, {}, {}, {}});
    return fields_.back();
  }

  std::vector<Field> fields_;
};

}  // namespace quadtune
