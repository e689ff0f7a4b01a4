#include "quadtune/layout/options.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "quadtune/common/error.hpp"
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
  void InRange(double v, const Range& range, const std::string& key) const {
    CheckInRange(v, range, file_, Key(key));
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
  [[nodiscard]] const std::string& file() const { return file_; }

 private:
  std::string file_;
  std::string prefix_;
};

void ValidateMix(const ObstacleMix& mix, const Checker& c) {
  c.InRange(mix.ring_fraction, Range::Closed(0.0, 1.0), "ring_fraction");
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

Interval ReadInterval(const YamlMap& m, std::string_view key, const Interval& fallback) {
  if (!m.Has(key)) return fallback;
  const std::vector<double> v = m.Numbers(key, 2);
  return {v[0], v[1]};
}

Eigen::Vector2d ReadVector2(const YamlMap& m, std::string_view key, const Eigen::Vector2d& fallback,
                            bool required = false) {
  if (!m.Has(key) && !required) return fallback;
  const std::vector<double> v = m.Numbers(key, 2);
  return {v[0], v[1]};
}

ObstacleMix ReadMix(const YamlMap& m, const ObstacleMix& base) {
  m.RejectUnknownKeys({"ring_fraction", "cylinder", "ring"});
  ObstacleMix mix = base;
  mix.ring_fraction = m.Number("ring_fraction", base.ring_fraction, Range::Closed(0.0, 1.0));
  const YamlMap cyl = m.Map("cylinder", true);
  cyl.RejectUnknownKeys({"radius", "height"});
  mix.cylinder.radius = ReadInterval(cyl, "radius", base.cylinder.radius);
  mix.cylinder.height = ReadInterval(cyl, "height", base.cylinder.height);
  const YamlMap ring = m.Map("ring", true);
  ring.RejectUnknownKeys({"radius", "thickness", "center_height", "yaw"});
  mix.ring.radius = ReadInterval(ring, "radius", base.ring.radius);
  mix.ring.thickness = ReadInterval(ring, "thickness", base.ring.thickness);
  mix.ring.center_height = ReadInterval(ring, "center_height", base.ring.center_height);
  mix.ring.yaw = ReadInterval(ring, "yaw", base.ring.yaw);
  return mix;
}

void EmitInterval(YAML::Emitter& out, const char* key, const Interval& iv) {
  out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq << iv.min << iv.max
      << YAML::EndSeq;
}

void EmitVector(YAML::Emitter& out, const char* key, const double* v, int n) {
  out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int i = 0; i < n; ++i) out << v[i];
  out << YAML::EndSeq;
}

void EmitMix(YAML::Emitter& out, const ObstacleMix& mix) {
  out << YAML::BeginMap;
  out << YAML::Key << "ring_fraction" << YAML::Value << mix.ring_fraction;
  out << YAML::Key << "cylinder" << YAML::Value << YAML::BeginMap;
  EmitInterval(out, "radius", mix.cylinder.radius);
  EmitInterval(out, "height", mix.cylinder.height);
  out << YAML::EndMap;
  out << YAML::Key << "ring" << YAML::Value << YAML::BeginMap;
  EmitInterval(out, "radius", mix.ring.radius);
  EmitInterval(out, "thickness", mix.ring.thickness);
  EmitInterval(out, "center_height", mix.ring.center_height);
  EmitInterval(out, "yaw", mix.ring.yaw);
  out << YAML::EndMap;
  out << YAML::EndMap;
}

}  // namespace

const char* ToString(DensityDefinition d) {
  return d == DensityDefinition::kArea ? "area" : "nearest_neighbour";
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
  // Scalars.
  c.InRange(spacing, Range::Positive(), "spacing");
  c.InRange(min_gap, Range::NonNegative(), "min_gap");
  c.InRange(hard_core_ratio, {0.0, 0.9, true, false}, "hard_core_ratio");
  c.InRange(tolerance, {0.0, 0.1, true, false}, "tolerance");
  c.InRange(static_cast<double>(max_rejections), Range::Closed(100.0, 1e8), "max_rejections");
  // Region and mission.
  c.Finite(region.min_W, "region.min");
  c.Finite(region.max_W, "region.max");
  if (!(region.max_W.array() > region.min_W.array()).all()) {
    c.Fail("region.max", "must exceed region.min in x and in y");
  }
  c.Finite(mission.start_W, "mission.start");
  c.Finite(mission.goal_W, "mission.goal");
  c.InRange(mission.keep_out_radius, Range::NonNegative(), "mission.keep_out_radius");
  for (std::size_t i = 0; i < keep_out.size(); ++i) {
    const std::string k = "keep_out[" + std::to_string(i) + "]";
    c.Finite(keep_out[i].center_W, k + ".center");
    c.InRange(keep_out[i].radius, Range::Positive(), k + ".radius");
  }
  // Obstacle mixtures.
  ValidateMix(obstacles, c.Sub("obstacles"));
  for (std::size_t i = 0; i < zones.size(); ++i) {
    if (zones[i].obstacles) {
      ValidateMix(*zones[i].obstacles, c.Sub("zones[" + std::to_string(i) + "].obstacles"));
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
    c.InRange(z.spacing, Range::Positive(), k + ".spacing");
  }
  // Densities the obstacles allow, and a region large enough for them.
  const std::vector<ZoneOptions> effective = EffectiveZones();
  for (std::size_t i = 0; i < effective.size(); ++i) {
    const ObstacleMix& mix = MixOf(effective[i]);
    const std::string k = zones.empty() ? "spacing" : "zones[" + std::to_string(i) + "].spacing";
    const double required = mix.RequiredSpacing(min_gap);
    if (effective[i].spacing < required) {
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
  map.RejectUnknownKeys({"region", "mission", "keep_out", "spacing", "density", "obstacles",
                         "zones", "min_gap", "hard_core_ratio", "tolerance", "max_rejections",
                         "ground"});
  LayoutOptions o;
  const YamlMap region = map.Map("region", true);
  region.RejectUnknownKeys({"min", "max"});
  o.region.min_W = ReadVector2(region, "min", o.region.min_W);
  o.region.max_W = ReadVector2(region, "max", o.region.max_W);

  const YamlMap mission = map.Map("mission", true);
  mission.RejectUnknownKeys({"start", "goal", "keep_out_radius"});
  o.mission.start_W = mission.Vector3("start", o.mission.start_W);
  o.mission.goal_W = mission.Vector3("goal", o.mission.goal_W);
  o.mission.keep_out_radius =
      mission.Number("keep_out_radius", o.mission.keep_out_radius, Range::NonNegative());

  for (const YamlMap& k : map.Maps("keep_out")) {
    k.RejectUnknownKeys({"center", "radius"});
    o.keep_out.push_back({ReadVector2(k, "center", {}, /*required=*/true),
                          k.Number("radius", std::nullopt, Range::Positive())});
  }

  o.spacing = map.Number("spacing", o.spacing, Range::Positive());
  o.density = map.String("density", "area", {"area", "nearest_neighbour"}) == "area"
                  ? DensityDefinition::kArea
                  : DensityDefinition::kNearestNeighbour;
  o.obstacles = ReadMix(map.Map("obstacles", true), o.obstacles);
  for (const YamlMap& z : map.Maps("zones")) {
    z.RejectUnknownKeys({"x_range", "spacing", "obstacles"});
    ZoneOptions zone;
    const std::vector<double> x = z.Numbers("x_range", 2);
    zone.x_min = x[0];
    zone.x_max = x[1];
    zone.spacing = z.Number("spacing", std::nullopt, Range::Positive());
    if (z.Has("obstacles")) zone.obstacles = ReadMix(z.Map("obstacles"), o.obstacles);
    o.zones.push_back(zone);
  }
  o.min_gap = map.Number("min_gap", o.min_gap, Range::NonNegative());
  o.hard_core_ratio = map.Number("hard_core_ratio", o.hard_core_ratio, {0.0, 0.9, true, false});
  o.tolerance = map.Number("tolerance", o.tolerance, {0.0, 0.1, true, false});
  o.max_rejections = map.Integer("max_rejections", o.max_rejections, Range::Closed(100.0, 1e8));
  o.ground = map.Bool("ground", o.ground);
  o.Validate(map.file(), map.path());
  return o;
}

LayoutOptions LayoutOptions::LoadFile(const std::string& path) {
  return FromYaml(YamlMap::LoadFile(path));
}

void LayoutOptions::ToYaml(YAML::Emitter& out) const {
  SetExactDoubles(out);
  out << YAML::BeginMap;
  out << YAML::Key << "region" << YAML::Value << YAML::BeginMap;
  EmitVector(out, "min", region.min_W.data(), 2);
  EmitVector(out, "max", region.max_W.data(), 2);
  out << YAML::EndMap;
  out << YAML::Key << "mission" << YAML::Value << YAML::BeginMap;
  EmitVector(out, "start", mission.start_W.data(), 3);
  EmitVector(out, "goal", mission.goal_W.data(), 3);
  out << YAML::Key << "keep_out_radius" << YAML::Value << mission.keep_out_radius;
  out << YAML::EndMap;
  out << YAML::Key << "keep_out" << YAML::Value << YAML::BeginSeq;
  for (const KeepOutZone& k : keep_out) {
    out << YAML::Flow << YAML::BeginMap;
    EmitVector(out, "center", k.center_W.data(), 2);
    out << YAML::Key << "radius" << YAML::Value << k.radius;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "spacing" << YAML::Value << spacing;
  out << YAML::Key << "density" << YAML::Value << ToString(density);
  out << YAML::Key << "obstacles" << YAML::Value;
  EmitMix(out, obstacles);
  out << YAML::Key << "zones" << YAML::Value << YAML::BeginSeq;
  for (const ZoneOptions& z : zones) {
    out << YAML::BeginMap;
    const double x[2] = {z.x_min, z.x_max};
    EmitVector(out, "x_range", x, 2);
    out << YAML::Key << "spacing" << YAML::Value << z.spacing;
    if (z.obstacles) {
      out << YAML::Key << "obstacles" << YAML::Value;
      EmitMix(out, *z.obstacles);
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "min_gap" << YAML::Value << min_gap;
  out << YAML::Key << "hard_core_ratio" << YAML::Value << hard_core_ratio;
  out << YAML::Key << "tolerance" << YAML::Value << tolerance;
  out << YAML::Key << "max_rejections" << YAML::Value << max_rejections;
  out << YAML::Key << "ground" << YAML::Value << ground;
  out << YAML::EndMap;
}

}  // namespace quadtune::layout
