#pragma once
/// \file
/// Column lists: one list per stored record type says, for every column, its name, its member,
/// how it is stored and what it means (as a field list, fields.hpp, does for configuration).
/// Every reader and writer of stored rows walks the list instead of naming the members: the
/// results store's SQL table, row reader and insert, the binary row codec, the JSON of the
/// distributed path, the CSV and tidy exports, and the Python loader (which reads the list from
/// the store's `stored_column` table). Adding a member to a record and one line to its list
/// adds the column everywhere.
///
/// ```
/// const Columns<EvaluationRow>& EvaluationColumns() {
///   static const Columns<EvaluationRow> columns = Columns<EvaluationRow>()
///       .Integer("trial_id", &EvaluationRow::trial_id, "the trial's id")
///       .Enum("kind", &EvaluationRow::kind, "what was evaluated")
///       .Real("value", &EvaluationRow::value, "objective value");
///   return columns;
/// }
/// ```
///
/// Thread safety: a Columns object is immutable once built; concurrent reads are safe.

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <variant>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/error.hpp"

namespace quadtune {

/// How a column's value is held and stored.
enum class ColumnType {
  kInteger,  ///< a signed integer (SQL INTEGER)
  kReal,     ///< a double, exact to the bit in the codec and the distributed JSON (SQL REAL)
  kText,     ///< free text (SQL TEXT)
  kSeed,     ///< a 64-bit seed, stored as decimal text (SQLite integers are signed); 0 as ""
  kEnum,     ///< one name of an enum's name table (SQL TEXT)
  kObject,   ///< a JSON object of numbers, stored as its text; exports give one column per key
  kValues,   ///< a name → number map held as a map (records that are not stored rows)
};
constexpr auto EnumNames(ColumnType) {
  return std::array{EnumName{ColumnType::kInteger, "integer"},
                    EnumName{ColumnType::kReal, "real"},
                    EnumName{ColumnType::kText, "text"},
                    EnumName{ColumnType::kSeed, "seed"},
                    EnumName{ColumnType::kEnum, "enum"},
                    EnumName{ColumnType::kObject, "object"},
                    EnumName{ColumnType::kValues, "values"}};
}

/// A column's value: kInteger → int64, kReal → double, kText, kEnum (its name) and kObject →
/// string, kSeed → uint64, kValues → map.
using ColumnValue =
    std::variant<std::int64_t, double, std::string, std::uint64_t, std::map<std::string, double>>;

/// Thrown by Column::set for a value its column cannot hold (an enum name outside the table).
class ColumnError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

template <class T>
class Columns {
 public:
  struct Column {
    std::string name;                ///< in JSON, the exports and Python
    std::string sql;                 ///< the SQL column (the name unless StoredAs)
    ColumnType type = ColumnType::kText;
    /// kEnum: the allowed names, in table order; kObject: its typed keys (KeyTypes)
  std::vector<std::string> names;
    /// kObject: the prefix a key gets in the exports when another column has its name
    std::string prefix;
    std::string meaning;
    std::function<ColumnValue(const T&)> get;
    std::function<void(T&, const ColumnValue&)> set;  ///< throws ColumnError
  };

  /// An integral member (int, std::int64_t, ...).
  template <class I>
    requires std::is_integral_v<I> && (!std::is_same_v<I, bool>)
  Columns& Integer(std::string name, I T::*member, std::string meaning) {
    Column& c = Add(std::move(name), ColumnType::kInteger, std::move(meaning));
    c.get = [member](const T& t) { return ColumnValue(static_cast<std::int64_t>(t.*member)); };
    c.set = [member](T& t, const ColumnValue& v) {
      t.*member = static_cast<I>(std::get<std::int64_t>(v));
    };
    return *this;
  }
  Columns& Real(std::string name, double T::*member, std::string meaning) {
    Column& c = Add(std::move(name), ColumnType::kReal, std::move(meaning));
    c.get = [member](const T& t) { return ColumnValue(t.*member); };
    c.set = [member](T& t, const ColumnValue& v) { t.*member = std::get<double>(v); };
    return *this;
  }
  Columns& Text(std::string name, std::string T::*member, std::string meaning) {
    return Textual(std::move(name), ColumnType::kText, member, std::move(meaning));
  }
  /// A string member holding a JSON object of numbers; the exports give each key a column of
  /// its own, named `prefix` + key where another column has the key's name.
  Columns& Object(std::string name, std::string T::*member, std::string prefix,
                  std::string meaning) {
    Textual(std::move(name), ColumnType::kObject, member, std::move(meaning));
    columns_.back().prefix = std::move(prefix);
    return *this;
  }
  Columns& Seed(std::string name, std::uint64_t T::*member, std::string meaning) {
    Column& c = Add(std::move(name), ColumnType::kSeed, std::move(meaning));
    c.get = [member](const T& t) { return ColumnValue(t.*member); };
    c.set = [member](T& t, const ColumnValue& v) { t.*member = std::get<std::uint64_t>(v); };
    return *this;
  }
  /// An enum member, held as its name (enum_names.hpp).
  template <NamedEnum E>
  Columns& Enum(std::string name, E T::*member, std::string meaning) {
    Column& c = Add(std::move(name), ColumnType::kEnum, std::move(meaning));
    c.names = EnumNameList<E>();
    c.get = [member](const T& t) { return ColumnValue(std::string(ToString(t.*member))); };
    c.set = [member, key = c.name](T& t, const ColumnValue& v) {
      const std::string& text = std::get<std::string>(v);
      const std::optional<E> e = FromString<E>(text);
      if (!e) {
        std::string allowed;
        for (const auto& n : EnumNameList<E>()) allowed += (allowed.empty() ? "" : ", ") + n;
        throw ColumnError(key + ": '" + text + "' is not one of " + allowed);
      }
      t.*member = *e;
    };
    return *this;
  }
  /// A name → number map member.
  Columns& Values(std::string name, std::map<std::string, double> T::*member,
                  std::string meaning) {
    Column& c = Add(std::move(name), ColumnType::kValues, std::move(meaning));
    c.get = [member](const T& t) { return ColumnValue(t.*member); };
    c.set = [member](T& t, const ColumnValue& v) {
      t.*member = std::get<std::map<std::string, double>>(v);
    };
    return *this;
  }
  /// The last column (kObject): its keys whose values are whole numbers ("key:integer") or 0/1
  /// flags ("key:boolean"), kept in `names`. The tidy export and the Python loader type those
  /// keys so; every other key is a real.
  Columns& KeyTypes(std::vector<std::string> typed) {
    Column& c = columns_.back();
    QT_DEMAND(c.type == ColumnType::kObject, "key types for '" + c.name + "', not an object");
    for (const std::string& t : typed) {
      const auto colon = t.rfind(':');
      const std::string type = colon == std::string::npos ? "" : t.substr(colon + 1);
      QT_DEMAND(type == "integer" || type == "boolean",
                "key type '" + t + "' of '" + c.name + "': key:integer or key:boolean");
    }
    c.names = std::move(typed);
    return *this;
  }
  /// The last column's SQL name, where its name is an SQL keyword.
  Columns& StoredAs(std::string sql) {
    columns_.back().sql = std::move(sql);
    return *this;
  }

  [[nodiscard]] const std::vector<Column>& List() const { return columns_; }

 private:
  Columns& Textual(std::string name, ColumnType type, std::string T::*member,
                   std::string meaning) {
    Column& c = Add(std::move(name), type, std::move(meaning));
    c.get = [member](const T& t) { return ColumnValue(t.*member); };
    c.set = [member](T& t, const ColumnValue& v) { t.*member = std::get<std::string>(v); };
    return *this;
  }
  Column& Add(std::string name, ColumnType type, std::string meaning) {
    for (const Column& c : columns_) {
      QT_DEMAND(c.name != name, "column '" + name + "' listed twice");
    }
    Column c;
    c.sql = name;
    c.name = std::move(name);
    c.type = type;
    c.meaning = std::move(meaning);
    columns_.push_back(std::move(c));
    return columns_.back();
  }

  std::vector<Column> columns_;
};

}  // namespace quadtune
