#include "quadtune/common/fields.hpp"

#include <array>
#include <charconv>
#include <cmath>

namespace quadtune {

std::string FormatNumber(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  if (std::isnan(v)) return "nan";
  if (v == std::floor(v) && std::fabs(v) < 1e15) {
    return std::to_string(static_cast<long long>(v));
  }
  std::array<char, 32> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), v);
  return std::string(buffer.data(), result.ptr);
}

std::string DescribeInterval(const Range& range) {
  if (std::isinf(range.lo) && std::isinf(range.hi)) return "";
  return std::string(range.lo_open || std::isinf(range.lo) ? "(" : "[") + FormatNumber(range.lo) +
         ", " + FormatNumber(range.hi) + (range.hi_open || std::isinf(range.hi) ? ")" : "]");
}

std::string CodeList(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "`" : ", `") + n + "`";
  return out;
}

namespace {
/// `text` fit for a table cell: a bar written as \| (GitHub's tables read it so, in code too).
std::string Cell(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '|') out += '\\';
    out += c;
  }
  return out;
}
}  // namespace

std::string MarkdownTable(const std::vector<FieldDoc>& rows) {
  std::string out = "| key | type | default | allowed | meaning |\n|---|---|---|---|---|\n";
  for (const FieldDoc& r : rows) {
    out += "| `" + Cell(r.key) + "` | " + Cell(r.type) + " | " + Cell(r.fallback) + " | " +
           Cell(r.allowed) + " | " + Cell(r.meaning) + " |\n";
  }
  return out;
}

}  // namespace quadtune
