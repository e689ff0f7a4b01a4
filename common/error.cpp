#include "quadtune/common/error.hpp"

#include <sstream>

namespace quadtune {
namespace {
std::string Compose(const std::string& file, const std::string& key, const std::string& message) {
  std::string out;
  if (!file.empty()) out += file + ": ";
  if (!key.empty()) out += key + ": ";
  return out + message;
}
}  // namespace

ConfigError::ConfigError(std::string file, std::string key, const std::string& message)
    : std::invalid_argument(Compose(file, key, message)),
      file_(std::move(file)),
      key_(std::move(key)) {}

namespace detail {
void DemandFailed(const char* condition, const char* file, int line, const std::string& message) {
  std::ostringstream out;
  out << "internal invariant failed: (" << condition << ") at " << file << ":" << line;
  if (!message.empty()) out << ": " << message;
  throw InvariantError(out.str());
}
}  // namespace detail
}  // namespace quadtune
