#include "quadtune/common/yaml.hpp"
#include "quadtune/common/text_file.hpp"

#include <yaml-cpp/depthguard.h>

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <charconv>
#include <cstdint>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>
#include <utility>

namespace quadtune {
namespace {
std::string FormatBound(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  std::ostringstream s;
  s << v;
  return s.str();
}

std::string JoinAllowed(const std::vector<std::string>& allowed) {
  std::string out;
  for (const auto& a : allowed) out += (out.empty() ? "" : ", ") + a;
  return out;
}

/// The parse of `text` (from `origin`): not UTF-8, or a shape CheckYamlShape refuses, is a
/// ConfigError.
YAML::Node ParseChecked(const std::string& text, const std::string& origin,
                        const YamlBounds& bounds) {
  if (!IsValidUtf8(text)) {
    // Name the first line that holds a byte sequence that is not UTF-8.
    std::size_t line_start = 0;
    int line = 1;
    for (std::size_t nl = text.find('\n'); ; nl = text.find('\n', line_start)) {
      const std::size_t end = nl == std::string::npos ? text.size() : nl;
      if (!IsValidUtf8(std::string_view(text).substr(line_start, end - line_start))) break;
      if (nl == std::string::npos) break;
      line_start = nl + 1;
      ++line;
    }
    throw ConfigError(origin, "", "line " + std::to_string(line) +
                                      " is not valid UTF-8 text (YAML files are UTF-8)");
  }
  try {
    CheckYamlShape(text, origin, "", bounds);
    return YAML::Load(text);  // within the limits, without aliases: linear in the text
  } catch (const YAML::DeepRecursion& e) {
    throw ConfigError(origin, "", "nesting deeper than yaml-cpp's limit at line " +
                                      std::to_string(e.mark.line + 1));
  } catch (const YAML::Exception& e) {
    throw ConfigError(origin, "", "malformed YAML at line " + std::to_string(e.mark.line + 1) +
                                      ": " + e.msg);
  }
}
}  // namespace

bool IsValidUtf8(std::string_view text) {
  std::size_t i = 0;
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    std::size_t extra = 0;
    std::uint32_t cp = 0;
    if (c < 0x80) {
      ++i;
      continue;
    } else if ((c & 0xE0) == 0xC0) {
      extra = 1;
      cp = c & 0x1Fu;
    } else if ((c & 0xF0) == 0xE0) {
      extra = 2;
      cp = c & 0x0Fu;
    } else if ((c & 0xF8) == 0xF0) {
      extra = 3;
      cp = c & 0x07u;
    } else {
      return false;
    }
    if (i + extra >= text.size()) return false;
    for (std::size_t k = 1; k <= extra; ++k) {
      const auto cc = static_cast<unsigned char>(text[i + k]);
      if ((cc & 0xC0) != 0x80) return false;
      cp = (cp << 6) | (cc & 0x3Fu);
    }
    // Overlong forms, surrogates and code points beyond U+10FFFF are not UTF-8.
    static constexpr std::uint32_t kMin[] = {0, 0x80, 0x800, 0x10000};
    if (cp < kMin[extra] || cp > 0x10FFFF || (cp >= 0xD800 && cp <= 0xDFFF)) return false;
    i += extra + 1;
  }
  return true;
}

bool PathExists(const std::string& path) noexcept {
  std::error_code ec;
  return std::filesystem::exists(path, ec) && !ec;
}

std::string FileProblem(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (ec || !fs::exists(st)) return "cannot open the file: no such file";
  if (fs::is_directory(st)) return "is a directory; expected a file";
  if (!fs::is_regular_file(st)) return "is not a regular file";
  return "";
}

void WriteFileAtomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (f == nullptr) {
    throw ConfigError(path, "", std::string("cannot write the file: ") + std::strerror(errno));
  }
  const bool written = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (!written || !closed || std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = !written ? write_errno : errno;
    std::remove(tmp.c_str());
    throw ConfigError(path, "", std::string("cannot write the file: ") + std::strerror(err));
  }
}

std::string ReadFileText(const std::string& path) {
  namespace fs = std::filesystem;
  if (const std::string why = FileProblem(path); !why.empty()) throw ConfigError(path, "", why);
  std::error_code ec;
  const std::uintmax_t bytes = fs::file_size(path, ec);
  if (!ec && bytes > kMaxYamlBytes) {
    throw ConfigError(path, "", std::to_string(bytes) + " bytes; a configuration file holds at most " +
                                    std::to_string(kMaxYamlBytes) +
                                    " (the limit bounds the memory of reading)");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw ConfigError(path, "", std::string("cannot open the file: ") + std::strerror(errno));
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) throw ConfigError(path, "", "cannot read the file");
  return ss.str();
}

bool Range::Contains(double v) const {
  if (!std::isfinite(v)) return false;
  if (lo_open ? !(v > lo) : !(v >= lo)) return false;
  if (hi_open ? !(v < hi) : !(v <= hi)) return false;
  return true;
}

std::string Range::Describe() const {
  if (std::isinf(lo) && std::isinf(hi)) return "a finite number";
  return std::string("a number in ") + (lo_open || std::isinf(lo) ? "(" : "[") + FormatBound(lo) +
         ", " + FormatBound(hi) + (hi_open || std::isinf(hi) ? ")" : "]");
}

void CheckInRange(double value, const Range& range, const std::string& file,
                  const std::string& key) {
  if (!range.Contains(value)) {
    std::ostringstream s;
    s << "got " << value << ", allowed: " << range.Describe();
    throw ConfigError(file, key, s.str());
  }
}

YamlMap YamlMap::LoadFile(const std::string& path, const YamlBounds& bounds) {
  return FromString(ReadFileText(path), path, bounds);
}

YamlMap YamlMap::FromString(const std::string& text, const std::string& origin,
                            const YamlBounds& bounds) {
  const YAML::Node root = ParseChecked(text, origin, bounds);
  if (!root.IsMap() && !root.IsNull()) {
    throw ConfigError(origin, "", "the top level must be a mapping of keys to values");
  }
  return YamlMap(root, origin);
}

YamlMap::YamlMap(YAML::Node node, std::string file, std::string path)
    : node_(std::move(node)), file_(std::move(file)), path_(std::move(path)) {
  if (!node_.IsMap() && !node_.IsNull() && node_.IsDefined()) {
    throw ConfigError(file_, path_, "expected a mapping of keys to values");
  }
}

void YamlMap::CheckFile(std::string_view key, const std::string& path,
                        const std::string& where) const {
  if (!PathExists(path)) Fail(key, "file '" + path + "' not found" + where);
  if (const std::string why = FileProblem(path); !why.empty()) Fail(key, "'" + path + "' " + why);
}

std::string YamlMap::KeyPath(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

void YamlMap::Fail(std::string_view key, const std::string& message) const {
  throw ConfigError(file_, KeyPath(key), message);
}

YAML::Node YamlMap::Lookup(std::string_view key) const {
  if (!node_.IsMap()) return YAML::Node(YAML::NodeType::Undefined);
  for (const auto& kv : node_) {
    if (kv.first.Scalar() == key) return kv.second;
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

bool YamlMap::Has(std::string_view key) const {
  const YAML::Node n = Lookup(key);
  return n.IsDefined() && !n.IsNull();
}

std::vector<std::string> YamlMap::Keys() const {
  std::vector<std::string> keys;
  if (!node_.IsMap()) return keys;
  for (const auto& kv : node_) keys.push_back(kv.first.Scalar());
  return keys;
}

double YamlMap::Number(std::string_view key, std::optional<double> fallback,
                       const Range& range) const {
  const YAML::Node n = Lookup(key);
  double v = 0.0;
  if (!n.IsDefined() || n.IsNull()) {
    if (!fallback) Fail(key, "missing; expected " + range.Describe());
    v = *fallback;
  } else {
    if (!n.IsScalar()) Fail(key, "expected " + range.Describe());
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      Fail(key, "'" + n.Scalar() + "' is not a number; expected " + range.Describe());
    }
  }
  CheckInRange(v, range, file_, KeyPath(key));
  return v;
}

long YamlMap::Integer(std::string_view key, std::optional<long> fallback,
                      const Range& range) const {
  const YAML::Node n = Lookup(key);
  long v = 0;
  if (!n.IsDefined() || n.IsNull()) {
    if (!fallback) Fail(key, "missing; expected an integer");
    v = *fallback;
  } else {
    if (!n.IsScalar()) Fail(key, "expected an integer");
    // Decimal only: "010" is ten (yaml-cpp would read it as octal), "0x10" is refused.
    const std::string& text = n.Scalar();
    const char* first = text.data();
    const char* last = text.data() + text.size();
    if (first != last && *first == '+') ++first;
    const auto [end, err] = std::from_chars(first, last, v, 10);
    if (first == last || err == std::errc::result_out_of_range) {
      Fail(key, "'" + text + "' is not an integer in [" +
                    std::to_string(std::numeric_limits<long>::min()) + ", " +
                    std::to_string(std::numeric_limits<long>::max()) + "]");
    }
    if (err != std::errc() || end != last) {
      Fail(key, "'" + text + "' is not an integer (decimal digits only, e.g. 10)");
    }
  }
  if (!range.Contains(static_cast<double>(v))) {
    Fail(key, "got " + std::to_string(v) + ", allowed: an integer in " +
                  range.Describe().substr(std::string("a number in ").size()));
  }
  return v;
}

bool YamlMap::Bool(std::string_view key, std::optional<bool> fallback) const {
  const YAML::Node n = Lookup(key);
  if (!n.IsDefined() || n.IsNull()) {
    if (!fallback) Fail(key, "missing; expected true or false");
    return *fallback;
  }
  try {
    return n.as<bool>();
  } catch (const YAML::Exception&) {
    Fail(key, "'" + (n.IsScalar() ? n.Scalar() : std::string("?")) +
                  "' is not a boolean; expected true or false");
  }
}

std::string YamlMap::String(std::string_view key, std::optional<std::string> fallback,
                            const std::vector<std::string>& allowed) const {
  const YAML::Node n = Lookup(key);
  std::string v;
  if (!n.IsDefined() || n.IsNull()) {
    if (!fallback) {
      Fail(key, allowed.empty() ? "missing; expected a string"
                                : "missing; expected one of: " + JoinAllowed(allowed));
    }
    v = *fallback;
  } else {
    if (!n.IsScalar()) Fail(key, "expected a string");
    v = n.Scalar();
    if (!IsValidUtf8(v)) Fail(key, "the text is not valid UTF-8");
    if (v.find('\0') != std::string::npos) {
      Fail(key, "the text holds a NUL byte (\\0) at offset " + std::to_string(v.find('\0')) +
                    "; text values cannot hold one (it would cut the stored text)");
    }
  }
  if (!allowed.empty()) {
    bool ok = false;
    for (const auto& a : allowed) ok = ok || a == v;
    if (!ok) Fail(key, "'" + v + "' is not allowed; expected one of: " + JoinAllowed(allowed));
  }
  return v;
}

Eigen::Vector3d YamlMap::Vector3(std::string_view key,
                                 std::optional<Eigen::Vector3d> fallback) const {
  if (!Has(key)) {
    if (!fallback) Fail(key, "missing; expected a sequence of three numbers [x, y, z]");
    return *fallback;
  }
  const std::vector<double> v = Numbers(key, 3);
  return {v[0], v[1], v[2]};
}

std::vector<double> YamlMap::Numbers(std::string_view key, int size) const {
  const YAML::Node n = Lookup(key);
  const std::string expect =
      size >= 0 ? "a sequence of " + std::to_string(size) + " numbers" : "a sequence of numbers";
  if (!n.IsDefined() || n.IsNull()) Fail(key, "missing; expected " + expect);
  if (!n.IsSequence()) Fail(key, "expected " + expect);
  if (size >= 0 && static_cast<int>(n.size()) != size) {
    Fail(key, "has " + std::to_string(n.size()) + " entries; expected " + expect);
  }
  std::vector<double> out;
  out.reserve(n.size());
  for (std::size_t i = 0; i < n.size(); ++i) {
    double v = 0.0;
    try {
      v = n[i].as<double>();
    } catch (const YAML::Exception&) {
      Fail(key, "entry " + std::to_string(i) + " is not a number; expected " + expect);
    }
    if (!std::isfinite(v)) Fail(key, "entry " + std::to_string(i) + " is not finite");
    out.push_back(v);
  }
  return out;
}

YamlMap YamlMap::Map(std::string_view key, bool optional) const {
  const YAML::Node n = Lookup(key);
  if (!n.IsDefined() || n.IsNull()) {
    if (!optional) Fail(key, "missing; expected a mapping of keys to values");
    return YamlMap(YAML::Node(YAML::NodeType::Map), file_, KeyPath(key));
  }
  if (!n.IsMap()) Fail(key, "expected a mapping of keys to values");
  return YamlMap(n, file_, KeyPath(key));
}

std::vector<YamlMap> YamlMap::Maps(std::string_view key) const {
  const YAML::Node n = Lookup(key);
  std::vector<YamlMap> out;
  if (!n.IsDefined() || n.IsNull()) return out;
  if (!n.IsSequence()) Fail(key, "expected a sequence of mappings");
  for (std::size_t i = 0; i < n.size(); ++i) {
    const std::string p = KeyPath(key) + "[" + std::to_string(i) + "]";
    if (!n[i].IsMap()) throw ConfigError(file_, p, "expected a mapping of keys to values");
    out.emplace_back(n[i], file_, p);
  }
  return out;
}

void YamlMap::RejectUnknownKeys(std::initializer_list<std::string_view> allowed) const {
  RejectUnknownKeys(std::vector<std::string>(allowed.begin(), allowed.end()));
}

void YamlMap::RejectUnknownKeys(const std::vector<std::string>& allowed) const {
  for (const std::string& k : Keys()) {
    bool ok = false;
    for (const auto& a : allowed) ok = ok || a == k;
    if (!ok) Fail(k, "unknown key; allowed keys here: " + JoinAllowed(allowed));
  }
}

void SetExactDoubles(YAML::Emitter& out) {
  out.SetDoublePrecision(17);
  out.SetFloatPrecision(9);
}

YAML::Node YamlDeepMerge(const YAML::Node& base, const YAML::Node& over) {
  if (!over.IsDefined() || over.IsNull()) return YAML::Clone(base);
  if (!base.IsMap() || !over.IsMap()) return YAML::Clone(over);
  YAML::Node out = YAML::Clone(base);
  for (const auto& kv : over) {
    const std::string key = kv.first.as<std::string>();
    out[key] = out[key].IsDefined() ? YamlDeepMerge(out[key], kv.second) : YAML::Clone(kv.second);
  }
  return out;
}

std::string YamlEmit(const YAML::Node& node) {
  YAML::Emitter emitter;
  SetExactDoubles(emitter);
  emitter << node;
  return emitter.c_str();
}

void YamlSetPath(YAML::Node root, const std::string& path, const YAML::Node& value,
                 const std::string& file, const std::string& key) {
  std::vector<std::string> parts;
  std::stringstream ss(path);
  for (std::string part; std::getline(ss, part, '.');) {
    if (part.empty()) throw ConfigError(file, key, "'" + path + "' has an empty part");
    parts.push_back(part);
  }
  if (parts.empty()) throw ConfigError(file, key, "must name a key, e.g. budget.flights");
  // yaml-cpp nodes are handles: walk down keeping one handle per level. In a sequence, a part
  // is an index (e.g. stages.1.override).
  auto index_of = [&](const YAML::Node& seq, const std::string& part) -> std::size_t {
    std::size_t pos = 0;
    unsigned long k = 0;
    try {
      k = std::stoul(part, &pos);
    } catch (const std::exception&) {
      pos = 0;
    }
    if (pos != part.size() || k >= seq.size()) {
      throw ConfigError(file, key, "'" + path + "': '" + part + "' must be an index below " +
                                       std::to_string(seq.size()) + " of a list");
    }
    return k;
  };
  // (Assigning to a YAML::Node writes through it, so the walk keeps one handle per level.)
  std::vector<YAML::Node> chain{root};
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    YAML::Node& node = chain.back();
    if (node.IsSequence()) {
      chain.push_back(node[index_of(node, parts[i])]);
      continue;
    }
    YAML::Node next = node[parts[i]];
    if (next.IsDefined() && !next.IsNull() && !next.IsMap() && !next.IsSequence()) {
      throw ConfigError(file, key, "'" + path + "': '" + parts[i] + "' is not a map");
    }
    if (!next.IsDefined() || next.IsNull()) node[parts[i]] = YAML::Node(YAML::NodeType::Map);
    chain.push_back(node[parts[i]]);
  }
  YAML::Node& last = chain.back();
  if (last.IsSequence()) {
    last[index_of(last, parts.back())] = value;
  } else {
    last[parts.back()] = value;
  }
}

std::string ApplyAssignments(const std::string& text, const std::vector<std::string>& assignments,
                             const std::string& file) {
  if (assignments.empty()) return text;
  YAML::Node root = YamlMap::FromString(text, file).node();
  if (!root.IsMap()) throw ConfigError(file, "", "must be a YAML map");
  for (const std::string& a : assignments) {
    const auto eq = a.find('=');
    if (eq == std::string::npos || eq == 0) {
      throw ConfigError(file, "--set", "'" + a + "' is not KEY=VALUE (e.g. budget.flights=10)");
    }
    const std::string key = "--set " + a.substr(0, eq);
    const std::string text = a.substr(eq + 1);
    YAML::Node value;
    try {
      CheckYamlShape(text, file, key);
      value = YAML::Load(text);
    } catch (const YAML::Exception& e) {
      throw ConfigError(file, "--set", "'" + a + "': the value is not YAML: " + e.msg);
    }
    YamlSetPath(root, a.substr(0, eq), value, file, key);
  }
  return YamlEmit(root);
}

}  // namespace quadtune
