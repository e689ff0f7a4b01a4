#include "quadtune/common/yaml.hpp"

#include <cmath>
#include <sstream>

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
}  // namespace

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

YamlMap YamlMap::LoadFile(const std::string& path) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path, "", "cannot open the file");
  } catch (const YAML::Exception& e) {
    throw ConfigError(path, "", "malformed YAML at line " + std::to_string(e.mark.line + 1) + ": " +
                                    e.msg);
  }
  if (!root.IsMap() && !root.IsNull()) {
    throw ConfigError(path, "", "the top level must be a mapping of keys to values");
  }
  return YamlMap(root, path);
}

YamlMap YamlMap::FromString(const std::string& text, const std::string& origin) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(origin, "", "malformed YAML at line " + std::to_string(e.mark.line + 1) +
                                      ": " + e.msg);
  }
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
    try {
      v = n.as<long>();
    } catch (const YAML::Exception&) {
      Fail(key, "'" + n.Scalar() + "' is not an integer");
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
    YAML::Node value;
    try {
      value = YAML::Load(a.substr(eq + 1));
    } catch (const YAML::Exception& e) {
      throw ConfigError(file, "--set", "'" + a + "': the value is not YAML: " + e.msg);
    }
    YamlSetPath(root, a.substr(0, eq), value, file, "--set " + a.substr(0, eq));
  }
  return YamlEmit(root);
}

}  // namespace quadtune
