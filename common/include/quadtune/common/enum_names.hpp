#pragma once
/// \file
/// One name table per enum, the single place where an enum's spellings live.
///
/// An enum joins by declaring, next to the enum and in its namespace, a constexpr function
/// `EnumNames(E)` that returns its table (found by argument-dependent lookup):
/// ```
/// enum class BoundHandling { kReflect, kClamp };
/// constexpr auto EnumNames(BoundHandling) {
///   return std::array{EnumName{BoundHandling::kReflect, "reflect"},
///                     EnumName{BoundHandling::kClamp, "clamp"}};
/// }
/// ```
/// Then `ToString(e)` gives the name, `FromString<E>(text)` the value (empty when the text names
/// none), and `EnumNameList<E>()` every name in table order, which is what configuration
/// readers list as allowed. The names are the spellings of the files, the command line and the
/// stored results.

#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace quadtune {

/// One row of an enum's name table.
template <class E>
struct EnumName {
  E value;
  const char* name;
};
/// Deduces EnumName<E> from a row (compilers without aggregate deduction need it: clang 14).
template <class E>
EnumName(E, const char*) -> EnumName<E>;

/// An enum with a name table (see the file comment).
template <class E>
concept NamedEnum = std::is_enum_v<E> && requires(E e) { EnumNames(e); };

/// The name of `value`; "?" for a value outside the table.
template <NamedEnum E>
[[nodiscard]] constexpr const char* ToString(E value) {
  for (const auto& row : EnumNames(E{})) {
    if (row.value == value) return row.name;
  }
  return "?";
}

/// The value named `name`; empty when no row has that name.
template <NamedEnum E>
[[nodiscard]] constexpr std::optional<E> FromString(std::string_view name) {
  for (const auto& row : EnumNames(E{})) {
    if (name == row.name) return row.value;
  }
  return std::nullopt;
}

/// Every name of E, in table order.
template <NamedEnum E>
[[nodiscard]] std::vector<std::string> EnumNameList() {
  std::vector<std::string> names;
  for (const auto& row : EnumNames(E{})) names.emplace_back(row.name);
  return names;
}

}  // namespace quadtune
