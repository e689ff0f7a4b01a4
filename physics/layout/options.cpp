#include "quadtune/layout/options.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <numbers>
#include <sstream>

#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::layout {
namespace {

std::string Num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Builds "prefix.key" (or "key" when the prefix is empty) and throws with it.
class Checker {
 public:
  Checker(std::string file, std::string prefix)
      : file_(std::move(file)), prefix_(std::move(prefix)) {}

  [[nodiscard]] std::string Key(const std::string& key) const {
    return prefix_.empty() ? key : prefix_ + "." + key;
  }
  [[noreturn]] void Fail(const std::string& key, const std::string& message) const {
    throw ConfigError(file_, Key(key), message);
  }
  void Finite(const Eigen::Vector2d& v, const std::string& key) const {
    if (!v.allFinite()) Fail(key, "every coordinate must be a finite number");
  }
  void Finite(const Eigen::Vector3d& v, const std::string& key) const {
    if (!v.allFinite()) Fail(key, "every coordinate must be a finite number");
  }
  // Both bounds inside `range` and min <= max.
  void CheckInterval(const Interval& iv, const Range& range, const std::string& key) const {
    if (!range.Contains(iv.min) || !range.Contains(iv.max)) {
      Fail(key, "got [" + Num(iv.min) + ", " + Num(iv.max) + "]; both bounds must be " +
                    range.Describe());
    }
    if (iv.min > iv.max) {
      Fail(key, "the lower bound " + Num(iv.min) + " exceeds the upper bound " + Num(iv.max) +
                    "; expected [min, max] with min <= max");
    }
  }
  [[nodiscard]] Checker Sub(const std::string& key) const { return {file_, Key(key)}; }
  // The prefix Fields::Check puts before a key: "prefix." (or nothing).
  [[nodiscard]] std::string Prefix() const { return prefix_.empty() ? "" : prefix_ + "."; }
  [[nodiscard]] const std::string& file() const { return file_; }

 private:
  std::string file_;
  std::string prefix_;
};

// The interval rules of a mixture (ring_fraction is checked by ObstacleMixFields()).
void ValidateIntervals(const ObstacleMix& mix, const Checker& c) {
  const Range finite = Range::Any();
  c.CheckInterval(mix.cylinder.radius, Range::Positive(), "cylinder.radius");
  c.CheckInterval(mix.cylinder.height, Range::Positive(), "cylinder.height");
  c.CheckInterval(mix.ring.radius, Range::Positive(), "ring.radius");
  c.CheckInterval(mix.ring.thickness, Range::Positive(), "ring.thickness");
  if (mix.ring.thickness.max >= 2.0 * mix.ring.radius.min) {
    c.Fail("ring.thickness", "the largest thickness " + Num(mix.ring.thickness.max) +
                                 " must be below twice the smallest ring radius (" +
                                 Num(2.0 * mix.ring.radius.min) + ")");
  }
  c.CheckInterval(mix.ring.center_height, finite, "ring.center_height");
  c.CheckInterval(mix.ring.yaw, finite, "ring.yaw");
}

using Pair = std::array<double, 2>;

// A key holding two numbers `[a, b]`: `get` takes them from a T, `set` stores them in one.
// Absent: the T keeps its values, or an error when `required`.
template <class T>
void AddPair(Fields<T>& fields, const std::string& key, std::string type, std::string allowed,
             std::string meaning, bool required, std::function<Pair(const T&)> get,
             std::function<void(T&, const Pair&)> set) {
  const Pair d = get(T{});
  fields.Custom(
      {key, std::move(type), "[" + FormatNumber(d[0]) + ", " + FormatNumber(d[1]) + "]",
       std::move(allowed), std::move(meaning)},
      [key, required, set](const YamlMap& m, T& t) {
        if (!required && !m.Has(key)) return;
        const std::vector<double> v = m.Numbers(key, 2);
        set(t, {v[0], v[1]});
      },
      [key, get](YAML::Emitter& out, const T& t) {
        const Pair v = get(t);
        out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq << v[0] << v[1]
            << YAML::EndSeq;
      });
  if (required) fields.Required();
}

template <class T>
void AddInterval(Fields<T>& fields, const std::string& key, Interval T::*member,
                 std::string allowed, std::string meaning) {
  AddPair<T>(
      fields, key, "[min, max]", std::move(allowed), std::move(meaning), /*required=*/false,
      [member](const T& t) {
        return Pair{(t.*member).min, (t.*member).max};
      },
      [member](T& t, const Pair& v) {
        t.*member = {v[0], v[1]};
      });
}

template <class T>
void AddVector2(Fields<T>& fields, const std::string& key, Eigen::Vector2d T::*member,
                std::string meaning, bool required = false) {
  AddPair<T>(
      fields, key, "[x, y]", "", std::move(meaning), required,
      [member](const T& t) {
        return Pair{(t.*member).x(), (t.*member).y()};
      },
      [member](T& t, const Pair& v) {
        t.*member = {v[0], v[1]};
      });
}

// A key holding a list of maps, each read and written by `item`; present, it replaces the
// list. Each item is read over `first(t)`.
template <class T, class I>
void AddList(Fields<T>& fields, FieldDoc doc, std::vector<I> T::*member, const Fields<I>& item,
             bool flow_items, std::function<I(const T&)> first) {
  const std::string key = doc.key;
  fields.Custom(
      std::move(doc),
      [key, member, &item, first](const YamlMap& m, T& t) {
        if (!m.Has(key)) return;
        std::vector<I> items;
        for (const YamlMap& map : m.Maps(key)) {
          I value = first(t);
          item.Read(map, value);
          items.push_back(std::move(value));
        }
        t.*member = std::move(items);
      },
      [key, member, &item, flow_items](YAML::Emitter& out, const T& t) {
        out << YAML::Key << key << YAML::Value << YAML::BeginSeq;
        for (const I& value : t.*member) {
          if (flow_items) out << YAML::Flow;
          item.Write(out, value);
        }
        out << YAML::EndSeq;
      });
}

}  // namespace

const Fields<Region>& RegionFields() {
  static const Fields<Region> fields = [] {
    Fields<Region> f;
    AddVector2(f, "min", &Region::min_W, "lower-left corner (m)");
    AddVector2(f, "max", &Region::max_W,
               "upper-right corner (m), above `min` in x and in y; the rectangle holds every "
               "footprint");
    return f;
  }();
  return fields;
}

const Fields<Mission>& MissionFields() {
  static const Fields<Mission> fields =
      Fields<Mission>()
          .Vector3("start", &Mission::start_W, "start of the flight the layout is made for (m)")
          .Vector3("goal", &Mission::goal_W, "goal of the flight the layout is made for (m)")
          .Number("keep_out_radius", &Mission::keep_out_radius, Range::NonNegative(),
                  "radius of the keep-out cylinders around start and goal (m); 0: none");
  return fields;
}

const Fields<KeepOutZone>& KeepOutFields() {
  static const Fields<KeepOutZone> fields = [] {
    Fields<KeepOutZone> f;
    AddVector2(f, "center", &KeepOutZone::center_W, "axis position (m)", /*required=*/true);
    f.Number("radius", &KeepOutZone::radius, Range::Positive(), "radius (m)").Required();
    return f;
  }();
  return fields;
}

const Fields<CylinderShape>& CylinderShapeFields() {
  static const Fields<CylinderShape> fields = [] {
    Fields<CylinderShape> f;
    AddInterval(f, "radius", &CylinderShape::radius, "(0, inf)", "cylinder radius range (m)");
    AddInterval(f, "height", &CylinderShape::height, "(0, inf)",
                "cylinder height range (m); cylinders stand on the ground");
    return f;
  }();
  return fields;
}

const Fields<RingShape>& RingShapeFields() {
  static const Fields<RingShape> fields = [] {
    Fields<RingShape> f;
    AddInterval(f, "radius", &RingShape::radius, "(0, inf)", "ring (major) radius range (m)");
    AddInterval(f, "thickness", &RingShape::thickness, "(0, inf), max < 2 × radius.min",
                "rim diameter range (m)");
    AddInterval(f, "center_height", &RingShape::center_height, "",
                "height range of the hole's centre (m); a ring that would cut the ground is "
                "raised");
    AddInterval(f, "yaw", &RingShape::yaw, "",
                "heading range of the ring's axis from +x about +z (rad); 0 faces a flight "
                "along +x");
    return f;
  }();
  return fields;
}

const Fields<ObstacleMix>& ObstacleMixFields() {
  static const Fields<ObstacleMix> fields =
      Fields<ObstacleMix>()
          .Number("ring_fraction", &ObstacleMix::ring_fraction, Range::Closed(0.0, 1.0),
                  "probability that an obstacle is a ring")
          .Nested("cylinder", &ObstacleMix::cylinder, CylinderShapeFields(),
                  "cylinder shape ranges (see Layout: obstacles.cylinder)")
          .Nested("ring", &ObstacleMix::ring, RingShapeFields(),
                  "ring shape ranges (see Layout: obstacles.ring)");
  return fields;
}

const Fields<ZoneOptions>& ZoneFields() {
  static const Fields<ZoneOptions> fields = [] {
    Fields<ZoneOptions> f;
    AddPair<ZoneOptions>(
        f, "x_range", "[x_min, x_max]", "x_min < x_max",
        "the zone's x-interval (m); zones are consecutive and cover the region", /*required=*/true,
        [](const ZoneOptions& z) {
          return Pair{z.x_min, z.x_max};
        },
        [](ZoneOptions& z, const Pair& v) {
          z.x_min = v[0];
          z.x_max = v[1];
        });
    f.Number("spacing", &ZoneOptions::spacing, Range::Positive(), "the zone's target spacing (m)")
        .Required();
    f.Custom(
        {"obstacles", "map", "the layout's `obstacles`", "",
         "the zone's mixture, over the layout's (keys as in `obstacles`)"},
        [](const YamlMap& m, ZoneOptions& z) {
          if (!m.Has("obstacles")) {
            z.obstacles.reset();
            return;
          }
          ObstacleMix mix = z.obstacles.value_or(ObstacleMix{});
          ObstacleMixFields().Read(m.Map("obstacles"), mix);
          z.obstacles = mix;
        },
        [](YAML::Emitter& out, const ZoneOptions& z) {
          if (!z.obstacles) return;
          out << YAML::Key << "obstacles" << YAML::Value;
          ObstacleMixFields().Write(out, *z.obstacles);
        });
    return f;
  }();
  return fields;
}

const Fields<LayoutOptions>& LayoutFields() {
  static const Fields<LayoutOptions> fields = [] {
    Fields<LayoutOptions> f;
    f.Nested("region", &LayoutOptions::region, RegionFields(),
             "rectangle that holds every footprint (see Layout: region)")
        .Nested("mission", &LayoutOptions::mission, MissionFields(),
                "the flight the layout is made for (see Layout: mission)");
    AddList<LayoutOptions, KeepOutZone>(f,
                                        {"keep_out", "list of `{center: [x, y], radius}`", "empty",
                                         "", "further keep-out cylinders (see Layout: keep_out)"},
                                        &LayoutOptions::keep_out, KeepOutFields(),
                                        /*flow_items=*/true,
                                        [](const LayoutOptions&) { return KeepOutZone{}; });
    f.Number("spacing", &LayoutOptions::spacing, Range::Positive(),
             "target spacing (m) when `zones` is absent; at least what the obstacles allow side "
             "by side")
        .Choice("density", &LayoutOptions::density, "what a spacing means (see Density above)")
        .Nested("obstacles", &LayoutOptions::obstacles, ObstacleMixFields(),
                "the obstacle mixture (see Layout: obstacles)");
    AddList<LayoutOptions, ZoneOptions>(
        f,
        {"zones", "list of `{x_range: [a, b], spacing, obstacles}`", "one zone over the region",
         "consecutive x-intervals covering the region",
         "density zones, each with its own spacing and optional mixture (see Layout: zones)"},
        &LayoutOptions::zones, ZoneFields(), /*flow_items=*/false, [](const LayoutOptions& o) {
          ZoneOptions zone;
          zone.obstacles = o.obstacles;  // a zone's mixture starts from the layout's
          return zone;
        });
    f.Number("min_gap", &LayoutOptions::min_gap, Range::NonNegative(),
             "least distance between two footprints (m)")
        .Number("hard_core_ratio", &LayoutOptions::hard_core_ratio, {0.0, 0.9, true, false},
                "no two centres of a zone closer than this times its spacing")
        .Number("tolerance", &LayoutOptions::tolerance, {0.0, 0.1, true, false},
                "relative tolerance on the achieved spacing (`nearest_neighbour` only)")
        .Integer("max_rejections", &LayoutOptions::max_rejections, Range::Closed(100.0, 1e8),
                 "darts rejected in a row before a zone is declared impossible")
        .Flag("ground", &LayoutOptions::ground, "ground plane at z = 0");
    return f;
  }();
  return fields;
}

double LayoutOptions::TargetCount(const ZoneOptions& zone) const {
  return std::max(1.0, std::round(ZoneArea(zone) / (4.0 * zone.spacing * zone.spacing)));
}

double ObstacleMix::MaxReach() const {
  double reach = 0.0;
  if (ring_fraction < 1.0) reach = std::max(reach, cylinder.radius.max);
  if (ring_fraction > 0.0) reach = std::max(reach, ring.radius.max + 0.5 * ring.thickness.max);
  return reach;
}

double ObstacleMix::RequiredSpacing(double min_gap) const {
  double width = 0.0;  // the widest a footprint can be across its narrowest direction
  if (ring_fraction < 1.0) width = std::max(width, 2.0 * cylinder.radius.max);
  if (ring_fraction > 0.0) width = std::max(width, ring.thickness.max);
  return width + min_gap;
}

std::vector<ZoneOptions> LayoutOptions::EffectiveZones() const {
  if (!zones.empty()) return zones;
  return {ZoneOptions{region.min_W.x(), region.max_W.x(), spacing, std::nullopt}};
}

std::vector<KeepOutZone> LayoutOptions::AllKeepOutZones() const {
  std::vector<KeepOutZone> all;
  if (mission.keep_out_radius > 0.0) {
    all.push_back({mission.start_W.head<2>(), mission.keep_out_radius});
    all.push_back({mission.goal_W.head<2>(), mission.keep_out_radius});
  }
  all.insert(all.end(), keep_out.begin(), keep_out.end());
  return all;
}

void LayoutOptions::Validate(const std::string& file, const std::string& key_prefix) const {
  const Checker c(file, key_prefix);
  // Numbers and their ranges (every mixture's ring_fraction included).
  LayoutFields().Check(*this, file, c.Prefix());
  for (std::size_t i = 0; i < zones.size(); ++i) {
    if (zones[i].obstacles) {
      ObstacleMixFields().Check(*zones[i].obstacles, file,
                                c.Sub("zones[" + std::to_string(i) + "].obstacles").Prefix());
    }
  }
  // Region and mission.
  c.Finite(region.min_W, "region.min");
  c.Finite(region.max_W, "region.max");
  if (!(region.max_W.array() > region.min_W.array()).all()) {
    c.Fail("region.max", "must exceed region.min in x and in y");
  }
  c.Finite(mission.start_W, "mission.start");
  c.Finite(mission.goal_W, "mission.goal");
  for (std::size_t i = 0; i < keep_out.size(); ++i) {
    const Checker k = c.Sub("keep_out[" + std::to_string(i) + "]");
    k.Finite(keep_out[i].center_W, "center");
    KeepOutFields().Check(keep_out[i], file, k.Prefix());
  }
  // Obstacle mixtures.
  ValidateIntervals(obstacles, c.Sub("obstacles"));
  for (std::size_t i = 0; i < zones.size(); ++i) {
    if (zones[i].obstacles) {
      ValidateIntervals(*zones[i].obstacles, c.Sub("zones[" + std::to_string(i) + "].obstacles"));
    }
  }
  // Zones: consecutive x-intervals covering the region.
  constexpr double kEps = 1e-9;
  for (std::size_t i = 0; i < zones.size(); ++i) {
    const std::string k = "zones[" + std::to_string(i) + "]";
    const ZoneOptions& z = zones[i];
    if (!std::isfinite(z.x_min) || !std::isfinite(z.x_max) || !(z.x_max > z.x_min)) {
      c.Fail(k + ".x_range", "got [" + Num(z.x_min) + ", " + Num(z.x_max) +
                                 "]; expected finite [x_min, x_max] with x_min < x_max");
    }
    const double expected_start = i == 0 ? region.min_W.x() : zones[i - 1].x_max;
    if (std::abs(z.x_min - expected_start) > kEps) {
      c.Fail(k + ".x_range",
             "starts at x = " + Num(z.x_min) + " but must start at " + Num(expected_start) +
                 (i == 0 ? " (region.min x): zones are consecutive x-intervals covering the region"
                         : " (where the previous zone ends): zones are consecutive"));
    }
    if (i + 1 == zones.size() && std::abs(z.x_max - region.max_W.x()) > kEps) {
      c.Fail(k + ".x_range", "the last zone ends at x = " + Num(z.x_max) + " but must end at " +
                                 Num(region.max_W.x()) + " (region.max x)");
    }
    ZoneFields().Check(z, file, c.Sub(k).Prefix());
  }
  // Densities the obstacles allow, and a region large enough for them.
  const std::vector<ZoneOptions> effective = EffectiveZones();
  for (std::size_t i = 0; i < effective.size(); ++i) {
    const ObstacleMix& mix = MixOf(effective[i]);
    const std::string k = zones.empty() ? "spacing" : "zones[" + std::to_string(i) + "].spacing";
    if (density == DensityDefinition::kFreeGap && effective[i].spacing < min_gap) {
      c.Fail(k, "target free gap " + Num(effective[i].spacing) + " m is smaller than min_gap (" +
                    Num(min_gap) +
                    " m), the least gap any two footprints keep; use a spacing >= "
                    "min_gap");
    }
    const double required = mix.RequiredSpacing(min_gap);
    if (density != DensityDefinition::kFreeGap && effective[i].spacing < required) {
      c.Fail(k, "target spacing " + Num(effective[i].spacing) +
                    " m is smaller than the obstacles allow: two of the widest obstacles need "
                    "their centres " +
                    Num(required) +
                    " m apart (2 x largest cylinder radius or largest ring thickness, plus "
                    "min_gap); use a spacing >= " +
                    Num(required) + " m or smaller obstacles");
    }
    const double diameter = 2.0 * mix.MaxReach();
    const Eigen::Vector2d size = region.max_W - region.min_W;
    if (size.x() < diameter || size.y() < diameter) {
      c.Fail("region", "the region (" + Num(size.x()) + " x " + Num(size.y()) +
                           " m) is too small for the largest obstacle footprint (" + Num(diameter) +
                           " m across)");
    }
  }
  // Layouts that could never finish.
  double total = 0.0;
  for (const ZoneOptions& z : effective) total += TargetCount(z);
  if (!(total <= kMaxObstaclesPerLayout)) {
    c.Fail(zones.empty() ? "spacing" : "zones",
           "the region (" + Num(region.Area()) + " m²) at this spacing asks for " + Num(total) +
               " obstacles (area / (4 spacing²) per zone); at most " + Num(kMaxObstaclesPerLayout) +
               " obstacles per layout are allowed: use a larger spacing or a smaller region");
  }
  double keep_out_area = 0.0;
  for (const KeepOutZone& k : AllKeepOutZones()) {
    keep_out_area += std::numbers::pi * k.radius * k.radius;
  }
  if (keep_out_area > 0.5 * region.Area()) {
    c.Fail("region", "the region (" + Num(region.Area()) +
                         " m²) is too small for the keep-out zones (" + Num(keep_out_area) +
                         " m² in total); they may cover at most half of it");
  }
}

LayoutOptions LayoutOptions::FromYaml(const YamlMap& map) {
  const LayoutOptions o = LayoutFields().Read(map);
  o.Validate(map.file(), map.path());
  return o;
}

LayoutOptions LayoutOptions::LoadFile(const std::string& path) {
  const YamlMap map = YamlMap::LoadFile(path);
  if (map.Has("format")) {  // the first key of every file Layout::Save writes
    throw ConfigError(
        path, "",
        "is a saved layout (written by `quadtune layout`), not layout generator "
        "options; give generator options here (e.g. assets/layouts/forest_thin_1p3.yaml), "
        "or fly the saved layout with `quadtune fly --layout FILE`");
  }
  return FromYaml(map);
}

void LayoutOptions::ToYaml(YAML::Emitter& out) const {
  SetExactDoubles(out);
  LayoutFields().Write(out, *this);
}

}  // namespace quadtune::layout
