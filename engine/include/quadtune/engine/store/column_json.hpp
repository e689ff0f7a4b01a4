#pragma once
/// \file
/// A record as one JSON object, a key per column of its column list (columns.hpp): the JSON
/// of the distributed path (reals as the bit patterns of the doubles, so that a record crosses
/// ranks exactly) and of the files the program writes (reals as numbers).
///
/// Thread safety: plain functions on caller-owned data.

#include <bit>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "quadtune/common/columns.hpp"

namespace quadtune::engine {

/// How reals are written: exact (their 64-bit pattern as an integer) or as JSON numbers.
enum class JsonReals { kBits, kNumbers };

/// One column's value as JSON; kValues maps as [[name, value], ...] (kBits) or an object.
inline nlohmann::json ColumnJson(const ColumnValue& v, ColumnType type, JsonReals reals) {
  const auto real = [reals](double x) {
    return reals == JsonReals::kBits ? nlohmann::json(std::bit_cast<std::uint64_t>(x))
                                     : nlohmann::json(x);
  };
  switch (type) {
    case ColumnType::kInteger: return std::get<std::int64_t>(v);
    case ColumnType::kReal: return real(std::get<double>(v));
    case ColumnType::kSeed: return std::get<std::uint64_t>(v);
    case ColumnType::kValues: {
      nlohmann::json out = reals == JsonReals::kBits ? nlohmann::json::array()
                                                     : nlohmann::json::object();
      for (const auto& [name, value] : std::get<std::map<std::string, double>>(v)) {
        if (reals == JsonReals::kBits) {
          out.push_back(nlohmann::json::array({name, real(value)}));
        } else {
          out[name] = value;
        }
      }
      return out;
    }
    default: return std::get<std::string>(v);
  }
}

/// The value ColumnJson(·, kBits) wrote.
inline ColumnValue ColumnFromJson(const nlohmann::json& j, ColumnType type) {
  const auto real = [](const nlohmann::json& x) {
    return std::bit_cast<double>(x.get<std::uint64_t>());
  };
  switch (type) {
    case ColumnType::kInteger: return j.get<std::int64_t>();
    case ColumnType::kReal: return real(j);
    case ColumnType::kSeed: return j.get<std::uint64_t>();
    case ColumnType::kValues: {
      std::map<std::string, double> out;
      for (const auto& pair : j) out[pair.at(0).get<std::string>()] = real(pair.at(1));
      return out;
    }
    default: return j.get<std::string>();
  }
}

/// `record` as one JSON object, a key per column of `columns`.
template <class T>
nlohmann::json ToJson(const T& record, const Columns<T>& columns, JsonReals reals) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& c : columns.List()) out[c.name] = ColumnJson(c.get(record), c.type, reals);
  return out;
}

/// The record ToJson(·, kBits) wrote. Throws nlohmann::json::exception for a missing key or a
/// value of the wrong type, ColumnError for an enum name outside its table.
template <class T>
T FromJson(const nlohmann::json& j, const Columns<T>& columns) {
  T record{};
  for (const auto& c : columns.List()) c.set(record, ColumnFromJson(j.at(c.name), c.type));
  return record;
}

}  // namespace quadtune::engine
