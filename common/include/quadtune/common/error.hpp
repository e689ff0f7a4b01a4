#pragma once
/// \file
/// Error types shared by every quadtune module.
///
/// - Bad user input (a configuration file, an out-of-range parameter) throws ConfigError, whose
///   message names the file, the key and what is allowed.
/// - Broken internal invariants throw InvariantError through QT_DEMAND.

#include <stdexcept>
#include <string>

namespace quadtune {

/// Bad user input. what() reads "<file>: <key>: <message>" (file and key omitted when empty).
class ConfigError : public std::invalid_argument {
 public:
  ConfigError(std::string file, std::string key, const std::string& message);

  /// The file that held the bad input ("" when it came from code).
  [[nodiscard]] const std::string& file() const noexcept { return file_; }
  /// The dotted key path of the bad value, e.g. "rotor.max_speed" ("" when not a key).
  [[nodiscard]] const std::string& key() const noexcept { return key_; }

 private:
  std::string file_;
  std::string key_;
};

/// A broken internal invariant: a bug in quadtune, not in the input.
class InvariantError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

namespace detail {
[[noreturn]] void DemandFailed(const char* condition, const char* file, int line,
                               const std::string& message);
}  // namespace detail

}  // namespace quadtune

/// Checks an internal invariant in every build type; throws quadtune::InvariantError naming the
/// condition, the source location and the message.
#define QT_DEMAND(condition, message)                                                    \
  do {                                                                                   \
    if (!(condition)) {                                                                  \
      ::quadtune::detail::DemandFailed(#condition, __FILE__, __LINE__, (message));       \
    }                                                                                    \
  } while (false)
