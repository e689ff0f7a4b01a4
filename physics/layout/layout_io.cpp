#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "footprint_grid.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/layout/footprint.hpp"
#include "quadtune/layout/layout.hpp"

namespace quadtune::layout {
namespace {

constexpr const char* kFormat = "quadtune.layout/1";

std::string Num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

void EmitStats(YAML::Emitter& out, const SpacingStats& s) {
  out << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "count" << YAML::Value << static_cast<unsigned long long>(s.count);
  out << YAML::Key << "mean" << YAML::Value << s.mean;
  out << YAML::Key << "std" << YAML::Value << s.std;
  out << YAML::Key << "min" << YAML::Value << s.min;
  out << YAML::Key << "max" << YAML::Value << s.max;
  out << YAML::EndMap;
}

std::size_t ReadCount(const YamlMap& m, std::string_view key) {
  return static_cast<std::size_t>(m.Integer(key, std::nullopt, Range::NonNegative()));
}

SpacingStats ReadStats(const YamlMap& m) {
  m.RejectUnknownKeys({"count", "mean", "std", "min", "max"});
  SpacingStats s;
  s.count = ReadCount(m, "count");
  s.mean = m.Number("mean", std::nullopt, Range::NonNegative());
  s.std = m.Number("std", std::nullopt, Range::NonNegative());
  s.min = m.Number("min", std::nullopt, Range::NonNegative());
  s.max = m.Number("max", std::nullopt, Range::NonNegative());
  return s;
}

}  // namespace

void Layout::Validate(const std::string& file) const {
  options.Validate(file, "options");
  obstacles.Validate(file);

  std::vector<Footprint> footprints;
  std::vector<std::string> names;
  for (std::size_t i = 0; i < obstacles.cylinders.size(); ++i) {
    footprints.push_back(FootprintOf(obstacles.cylinders[i]));
    names.push_back("obstacles.cylinders[" + std::to_string(i) + "]");
  }
  for (std::size_t i = 0; i < obstacles.rings.size(); ++i) {
    footprints.push_back(FootprintOf(obstacles.rings[i]));
    names.push_back("obstacles.rings[" + std::to_string(i) + "]");
  }
  constexpr double kSlack = 1e-9;  // m
  double max_reach = 0.0;
  const std::vector<KeepOutZone> keep_outs = options.AllKeepOutZones();
  for (std::size_t i = 0; i < footprints.size(); ++i) {
    const Footprint& f = footprints[i];
    const Eigen::Vector2d lo = f.Center() - f.HalfExtent();
    const Eigen::Vector2d hi = f.Center() + f.HalfExtent();
    if ((lo.array() < options.region.min_W.array() - kSlack).any() ||
        (hi.array() > options.region.max_W.array() + kSlack).any()) {
      throw ConfigError(file, names[i], "its footprint leaves the region");
    }
    for (const KeepOutZone& k : keep_outs) {
      if (FootprintGap(f, k.center_W) < k.radius - kSlack) {
        throw ConfigError(file, names[i],
                          "its footprint enters the keep-out cylinder of radius " + Num(k.radius) +
                              " m around (" + Num(k.center_W.x()) + ", " + Num(k.center_W.y()) +
                              ")");
      }
    }
    max_reach = std::max(max_reach, f.Reach());
  }
  detail::FootprintGrid grid(options.region, max_reach, options.min_gap);
  for (std::size_t i = 0; i < footprints.size(); ++i) {
    const long j = grid.FindConflict(footprints[i], kSlack);
    if (j >= 0) {
      throw ConfigError(
          file, names[i],
          "its footprint is " +
              Num(FootprintGap(footprints[i], footprints[static_cast<std::size_t>(j)])) +
              " m from the footprint of " + names[static_cast<std::size_t>(j)] +
              ", less than min_gap " + Num(options.min_gap) + " m");
    }
    grid.Add(footprints[i]);
  }
}

void Layout::ToYaml(YAML::Emitter& out) const {
  SetExactDoubles(out);
  out << YAML::BeginMap;
  out << YAML::Key << "format" << YAML::Value << kFormat;
  out << YAML::Key << "seed" << YAML::Value << static_cast<unsigned long long>(seed);
  out << YAML::Key << "options" << YAML::Value;
  options.ToYaml(out);

  out << YAML::Key << "obstacles" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "ground" << YAML::Value << obstacles.ground;
  out << YAML::Key << "cylinders" << YAML::Value << YAML::BeginSeq;
  for (const auto& c : obstacles.cylinders) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "center" << YAML::Value << YAML::Flow << YAML::BeginSeq << c.center_W.x()
        << c.center_W.y() << YAML::EndSeq;
    out << YAML::Key << "radius" << YAML::Value << c.radius;
    out << YAML::Key << "z_min" << YAML::Value << c.z_min;
    out << YAML::Key << "z_max" << YAML::Value << c.z_max;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "rings" << YAML::Value << YAML::BeginSeq;
  for (const auto& r : obstacles.rings) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "center" << YAML::Value << YAML::Flow << YAML::BeginSeq << r.center_W.x()
        << r.center_W.y() << r.center_W.z() << YAML::EndSeq;
    out << YAML::Key << "yaw" << YAML::Value << r.yaw;
    out << YAML::Key << "radius" << YAML::Value << r.radius;
    out << YAML::Key << "thickness" << YAML::Value << r.thickness;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::EndMap;

  out << YAML::Key << "stats" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "overall" << YAML::Value;
  EmitStats(out, stats.overall);
  out << YAML::Key << "zones" << YAML::Value << YAML::BeginSeq;
  for (const ZoneStats& z : stats.zones) {
    out << YAML::BeginMap;
    out << YAML::Key << "x_range" << YAML::Value << YAML::Flow << YAML::BeginSeq << z.x_min
        << z.x_max << YAML::EndSeq;
    out << YAML::Key << "target_spacing" << YAML::Value << z.target_spacing;
    out << YAML::Key << "spacing" << YAML::Value;
    EmitStats(out, z.spacing);
    out << YAML::Key << "cylinders" << YAML::Value << static_cast<unsigned long long>(z.cylinders);
    out << YAML::Key << "rings" << YAML::Value << static_cast<unsigned long long>(z.rings);
    out << YAML::Key << "darts" << YAML::Value << static_cast<unsigned long long>(z.darts);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::EndMap;
  out << YAML::EndMap;
}

std::string Layout::ToYamlString() const {
  YAML::Emitter out;
  ToYaml(out);
  return std::string(out.c_str()) + "\n";
}

void Layout::Save(const std::string& path) const {
  const std::string text = ToYamlString();
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw ConfigError(path, "", "cannot open the file for writing");
  file << text;
  file.flush();
  if (!file) throw ConfigError(path, "", "cannot write the file");
}

YamlBounds SavedLayoutBounds() {
  YamlBounds b;
  b.max_nodes = static_cast<std::size_t>(kMaxObstaclesPerLayout) * 12 + 10000;
  b.nodes_why = "a saved layout holds at most " + Num(kMaxObstaclesPerLayout) +
                " obstacles (the cap on generated layouts) of at most 12 values each";
  return b;
}

namespace {
/// A saved layout holds at most what the generator may make: refused before any obstacle is read.
void CheckObstacleCount(const YamlMap& obs) {
  const auto count = [&](const char* key) {
    if (!obs.Has(key)) return 0.0;  // also when `obstacles:` is empty (a null node)
    const YAML::Node n = obs.node()[key];
    return n.IsSequence() ? static_cast<double>(n.size()) : 0.0;
  };
  const double total = count("cylinders") + count("rings");
  if (total > kMaxObstaclesPerLayout) {
    obs.Fail("cylinders", Num(count("cylinders")) + " cylinders + " + Num(count("rings")) +
                              " rings = " + Num(total) + " obstacles; a layout holds at most " +
                              Num(kMaxObstaclesPerLayout) +
                              " (the cap on generated layouts, which bounds memory and the time "
                              "of building a world)");
  }
}
}  // namespace

Layout Layout::FromYaml(const YamlMap& map) {
  map.RejectUnknownKeys({"format", "seed", "options", "obstacles", "stats"});
  const std::string format = map.String("format", std::string(kFormat), {kFormat});
  (void)format;
  Layout layout;
  if (map.Has("seed")) {
    const YAML::Node n = map.node()["seed"];
    try {
      layout.seed = n.as<std::uint64_t>();
    } catch (const YAML::Exception&) {
      map.Fail("seed", "expected an unsigned 64-bit integer");
    }
  }
  layout.options = LayoutOptions::FromYaml(map.Map("options", true));

  const YamlMap obs = map.Map("obstacles", true);
  obs.RejectUnknownKeys({"ground", "cylinders", "rings"});
  CheckObstacleCount(obs);
  layout.obstacles.ground = obs.Bool("ground", true);
  for (const YamlMap& c : obs.Maps("cylinders")) {
    c.RejectUnknownKeys({"center", "radius", "z_min", "z_max"});
    physics::CylinderObstacle cyl;
    const std::vector<double> center = c.Numbers("center", 2);
    cyl.center_W = {center[0], center[1]};
    cyl.radius = c.Number("radius");
    cyl.z_min = c.Number("z_min");
    cyl.z_max = c.Number("z_max");
    layout.obstacles.cylinders.push_back(cyl);
  }
  for (const YamlMap& r : obs.Maps("rings")) {
    r.RejectUnknownKeys({"center", "yaw", "radius", "thickness"});
    physics::RingObstacle ring;
    ring.center_W = r.Vector3("center");
    ring.yaw = r.Number("yaw");
    ring.radius = r.Number("radius");
    ring.thickness = r.Number("thickness");
    layout.obstacles.rings.push_back(ring);
  }

  if (map.Has("stats")) {
    const YamlMap st = map.Map("stats");
    st.RejectUnknownKeys({"overall", "zones"});
    layout.stats.overall = ReadStats(st.Map("overall"));
    for (const YamlMap& z : st.Maps("zones")) {
      z.RejectUnknownKeys({"x_range", "target_spacing", "spacing", "cylinders", "rings", "darts"});
      ZoneStats zs;
      const std::vector<double> x = z.Numbers("x_range", 2);
      zs.x_min = x[0];
      zs.x_max = x[1];
      zs.target_spacing = z.Number("target_spacing", std::nullopt, Range::Positive());
      zs.spacing = ReadStats(z.Map("spacing"));
      zs.cylinders = ReadCount(z, "cylinders");
      zs.rings = ReadCount(z, "rings");
      zs.darts = ReadCount(z, "darts");
      layout.stats.zones.push_back(zs);
    }
    // Free gaps are measured, not saved.
    const LayoutStats measured = MeasureLayout(layout.obstacles, layout.options);
    for (std::size_t i = 0; i < layout.stats.zones.size() && i < measured.zones.size(); ++i) {
      layout.stats.zones[i].gap = measured.zones[i].gap;
    }
  } else {
    layout.stats = MeasureLayout(layout.obstacles, layout.options);  // a hand-written layout
  }
  layout.Validate(map.file());
  return layout;
}

Layout Layout::FromYamlString(const std::string& text, const std::string& origin) {
  return FromYaml(YamlMap::FromString(text, origin, SavedLayoutBounds()));
}

Layout Layout::Load(const std::string& path) {
  return FromYaml(YamlMap::LoadFile(path, SavedLayoutBounds()));
}

}  // namespace quadtune::layout
