#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/mark.h>
#include <yaml-cpp/parser.h>

#include <optional>
#include <sstream>
#include <string>
#include <unordered_set>
#include <vector>

#include "quadtune/common/error.hpp"
#include "quadtune/common/text_file.hpp"

namespace quadtune {
namespace {

std::string Line(const YAML::Mark& mark) { return "(line " + std::to_string(mark.line + 1) + ")"; }

/// Walks the parser's events once, keeping only the open mappings and lists: time linear in the
/// text, memory bounded by the depth and the keys of the open mappings. Paths are built only
/// for a message, so a long key is never copied once per entry below it.
class ShapeChecker final : public YAML::EventHandler {
 public:
  ShapeChecker(const std::string& origin, const std::string& root, const YamlBounds& bounds)
      : origin_(origin), root_(root), bounds_(bounds) {}

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { Leaf(mark, nullptr); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override {
    if (!frames_.empty() && !frames_.back().is_map) ++frames_.back().entries;  // its index
    Fail(Depth(), "an alias (*name) " + Line(mark) +
                      "; quadtune files do not use YAML anchors and aliases: write the value out");
  }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                const std::string& value) override {
    Leaf(mark, &value);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    Open(mark, false);
  }
  void OnSequenceEnd() override { Close(); }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    Open(mark, true);
  }
  void OnMapEnd() override { Close(); }

 private:
  struct Frame {
    bool is_map = false;
    bool at_key = true;          ///< a mapping's next node is a key
    std::size_t entries = 0;     ///< keys (mapping) or entries (list) so far
    std::string key;             ///< a mapping's current key
    std::unordered_set<std::string> keys;
  };

  std::size_t Depth() const { return frames_.size(); }

  /// The dotted path through the first `levels` open containers' current entries.
  std::string Path(std::size_t levels) const {
    std::string path = root_;
    for (std::size_t i = 0; i < levels; ++i) {
      const Frame& f = frames_[i];
      const std::string part = f.is_map ? (f.at_key ? "?" : f.key) : std::to_string(f.entries - 1);
      path += (path.empty() ? "" : ".") + part;
    }
    return path;
  }

  [[noreturn]] void Fail(std::size_t levels, const std::string& message) const {
    throw ConfigError(origin_, Path(levels), message);
  }

  /// Counts a node and places it in its parent: true when it is a key of a mapping.
  bool Enter(const YAML::Mark& mark, const std::string* scalar) {
    if (++nodes_ > bounds_.max_nodes) {
      Fail(Depth(), "more than " + std::to_string(bounds_.max_nodes) + " values in the text " +
                        Line(mark) + "; " + bounds_.nodes_why);
    }
    if (frames_.empty()) return false;
    Frame& top = frames_.back();
    if (!top.is_map) {
      if (++top.entries > kMaxYamlListEntries) {
        Fail(Depth() - 1, "more than " + std::to_string(kMaxYamlListEntries) +
                              " entries in one list " + Line(mark) +
                              "; no quadtune file needs more (the largest is a saved layout's "
                              "obstacles, at most 100000)");
      }
      return false;
    }
    if (!top.at_key) return false;
    if (++top.entries > kMaxYamlMapKeys) {
      Fail(Depth() - 1, "more than " + std::to_string(kMaxYamlMapKeys) +
                            " keys in one mapping " + Line(mark) +
                            "; no quadtune file needs more (the limit bounds the time of reading)");
    }
    if (scalar == nullptr) {
      // Not a bound: kept until the text has parsed, so that malformed YAML is named first.
      if (!bad_key_) {
        bad_key_ = ConfigError(origin_, Path(Depth()), "a key that is empty, a list or a mapping " +
                                                           Line(mark) + "; keys are plain names");
      }
      top.key = "?";
    } else {
      top.key = *scalar;
      if (!top.keys.insert(*scalar).second) {
        top.at_key = false;
        Fail(Depth(), "key given twice in one mapping " + Line(mark) + "; give each key once");
      }
    }
    top.at_key = false;
    return true;
  }

  /// After a value: its mapping expects a key next.
  void Done() {
    if (!frames_.empty() && frames_.back().is_map) frames_.back().at_key = true;
  }

  void Leaf(const YAML::Mark& mark, const std::string* scalar) {
    if (!Enter(mark, scalar)) Done();
  }

  void Open(const YAML::Mark& mark, bool is_map) {
    (void)Enter(mark, nullptr);  // a list or mapping as a key is refused there
    if (Depth() >= kMaxYamlDepth) {
      Fail(0, "nesting deeper than " + std::to_string(kMaxYamlDepth) + " levels " +
                        Line(mark) + "; quadtune files nest a few levels");
    }
    frames_.push_back(Frame{is_map, true, 0, {}, {}});
  }

  void Close() {
    frames_.pop_back();
    Done();
  }

  const std::string& origin_;
  const std::string& root_;
  const YamlBounds& bounds_;
  std::vector<Frame> frames_;
  std::size_t nodes_ = 0;

 public:
  /// The first key that is not a plain name, once the whole text has parsed.
  std::optional<ConfigError> bad_key_;
};

}  // namespace

void CheckYamlShape(const std::string& text, const std::string& origin, const std::string& key,
                    const YamlBounds& bounds) {
  if (text.size() > kMaxYamlBytes) {
    throw ConfigError(origin, key, std::to_string(text.size()) + " bytes of YAML; at most " +
                                       std::to_string(kMaxYamlBytes) +
                                       " (the limit bounds the memory of reading)");
  }
  std::istringstream in(text);
  ShapeChecker checker(origin, key, bounds);
  YAML::Parser parser(in);
  parser.HandleNextDocument(checker);
  if (checker.bad_key_) throw *checker.bad_key_;
}

}  // namespace quadtune
