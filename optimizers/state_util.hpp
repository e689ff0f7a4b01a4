#pragma once
// Internal helpers for JSON state (not installed): exact RNG and vector round trips.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "quadtune/common/random.hpp"

namespace quadtune::optimizers::detail {

inline std::string RngToString(const Rng& rng) {
  std::ostringstream os;
  os << rng;
  return os.str();
}

inline Rng RngFromString(const std::string& s) {
  std::istringstream is(s);
  Rng rng;
  is >> rng;
  if (is.fail()) throw std::invalid_argument("optimizer state: malformed RNG state");
  return rng;
}

inline nlohmann::json ToJson(const Eigen::VectorXd& v) {
  return nlohmann::json(std::vector<double>(v.data(), v.data() + v.size()));
}

inline Eigen::VectorXd VectorFromJson(const nlohmann::json& j, Eigen::Index size = -1) {
  if (!j.is_array()) throw std::invalid_argument("optimizer state: expected an array of numbers");
  const auto values = j.get<std::vector<double>>();
  if (size >= 0 && static_cast<Eigen::Index>(values.size()) != size) {
    throw std::invalid_argument("optimizer state: expected " + std::to_string(size) +
                                " numbers, got " + std::to_string(values.size()));
  }
  return Eigen::Map<const Eigen::VectorXd>(values.data(), static_cast<Eigen::Index>(values.size()));
}

/// Checks the method tag and dimension of a saved state.
inline void CheckHeader(const nlohmann::json& state, const std::string& method, int dim) {
  if (!state.is_object() || !state.contains("method") || !state.contains("dim")) {
    throw std::invalid_argument("optimizer state: not a saved optimizer state");
  }
  if (state.at("method").get<std::string>() != method) {
    throw std::invalid_argument("optimizer state: saved by '" + state.at("method").get<std::string>() +
                                "', cannot restore into '" + method + "'");
  }
  if (state.at("dim").get<int>() != dim) {
    throw std::invalid_argument("optimizer state: saved for dimension " +
                                std::to_string(state.at("dim").get<int>()) + ", this space has " +
                                std::to_string(dim));
  }
}

/// Runs `body`, turning JSON access errors into std::invalid_argument.
template <class F>
void WithJsonErrors(F&& body) {
  try {
    body();
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string("optimizer state: malformed: ") + e.what());
  }
}

}  // namespace quadtune::optimizers::detail
