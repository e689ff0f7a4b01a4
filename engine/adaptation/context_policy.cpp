// Free range, stopping risk and the context policy. See context_policy.hpp.
//
// Thread safety: pure functions and values.
#include "quadtune/engine/adaptation/context_policy.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::engine {
namespace {

// Free length (m) of the segment from p_W along the unit vector `dir` up to `range`.
double FreeLength(const planning::LocalMap& map, const Eigen::Vector3d& p_W,
                  const Eigen::Vector3d& dir, double range, bool inflated) {
  const std::optional<double> hit = map.SegmentCollision(p_W, p_W + range * dir, inflated);
  return hit ? *hit * range : range;
}

std::string Num(double v) { return FormatNumber(v); }

// The `disc` free range of MeasureFreeRange.
double DiscFreePath(const planning::LocalMap& map, const Eigen::Vector3d& p_W, double radius) {
  const double res = map.resolution();
  const int reach = static_cast<int>(std::ceil(radius / res));
  const planning::CellIndex centre = map.CellOf(p_W);
  const double r2 = (radius / res) * (radius / res);
  long cells = 0;
  long occupied = 0;
  for (int i = -reach; i <= reach; ++i) {
    for (int j = -reach; j <= reach; ++j) {
      if (static_cast<double>(i * i + j * j) > r2) continue;
      ++cells;
      if (map.IsOccupiedRawCell(centre + planning::CellIndex(i, j, 0))) ++occupied;
    }
  }
  const double cap = 10.0 * radius;
  if (occupied == 0) return cap;
  const double free_area = static_cast<double>(cells - occupied) * res * res;
  return std::min(cap, std::numbers::pi * free_area / (2.0 * static_cast<double>(occupied) * res));
}

}  // namespace

const Fields<FreeRangeOptions>& FreeRangeFields() {
  using F = FreeRangeOptions;
  static const Fields<F> fields =
      Fields<F>()
          .Choice("kind", &F::kind,
                  "`rays`: mean free-ray length over the sensor's cone; `disc`: mean free path "
                  "of the mapped disc of radius `range` (docs/design.md, \"Adaptation that sees "
                  "risk\")")
          .Number("half_angle_deg", &F::half_angle_deg, {0.0, 180.0, true, true},
                  "half-width of the ray fan about the heading (deg)")
          .Number("range", &F::range, Range::Positive(), "longest ray, or the disc's radius (m)")
          .Integer("rays", &F::rays, Range::Closed(1, 1000), "rays in the fan");
  return fields;
}

double MeasureFreeRange(const planning::LocalMap& map, const Eigen::Vector3d& p_W,
                        const Eigen::Vector3d& heading_W, const FreeRangeOptions& options) {
  if (options.kind == FreeRangeKind::kDisc) return DiscFreePath(map, p_W, options.range);
  Eigen::Vector2d h = heading_W.head<2>();
  h = h.norm() > 1e-9 ? h.normalized() : Eigen::Vector2d::UnitX();
  const double yaw0 = std::atan2(h.y(), h.x());
  const double half = options.half_angle_deg * std::numbers::pi / 180.0;
  double sum = 0.0;
  for (int i = 0; i < options.rays; ++i) {
    const double u = options.rays == 1 ? 0.5 : static_cast<double>(i) / (options.rays - 1);
    const double yaw = yaw0 - half + 2.0 * half * u;
    const Eigen::Vector3d dir(std::cos(yaw), std::sin(yaw), 0.0);
    sum += FreeLength(map, p_W, dir, options.range, /*inflated=*/false);
  }
  return sum / options.rays;
}

double StoppingRisk(const planning::Trajectory& trajectory, const planning::LocalMap& map,
                    double a_max, double range, double reaction_time, double inflation,
                    double check_dt) {
  if (trajectory.Empty()) return 0.0;
  constexpr double kClearanceSearch = 2.0;  // m
  const double duration = trajectory.Duration();
  double stopping = 0.0;
  double margin = 0.0;
  for (double t = 0.0;; t += check_dt) {
    const double tc = std::min(t, duration);
    const Eigen::Vector3d v = trajectory.Velocity(tc);
    const Eigen::Vector3d p = trajectory.Position(tc);
    const double speed = v.norm();
    if (speed > 1e-3) {
      const double stop = speed * speed / (2.0 * a_max);
      const double free = FreeLength(map, p, v / speed, std::min(range, stop + 1.0), true);
      stopping = std::max(stopping, stop - free);
    }
    if (reaction_time > 0.0) {
      const double needed = reaction_time * speed;
      const double clearance =
          map.RawClearance(p, std::min(kClearanceSearch, needed + inflation)) - inflation;
      margin = std::max(margin, needed - clearance);
    }
    if (tc >= duration) break;
  }
  return stopping * stopping + margin * margin;
}

const Fields<ContextPolicy>& ContextPolicyFields() {
  using P = ContextPolicy;
  static const Fields<P> fields =
      Fields<P>()
          .Nested("free_range", &P::measure, FreeRangeFields(),
                  "how the context (the free range ahead) is measured")
          .Custom(
              {"points", "list of `{free_range, v_des, label}`", "required",
               "at least two, free_range strictly increasing, v_des in (0, 15]",
               "the policy's points: v_des (m/s) at a measured free range (m)"},
              [](const YamlMap& map, P& p) {
                p.points.clear();
                for (const YamlMap& item : map.Maps("points")) {
                  item.RejectUnknownKeys({"free_range", "v_des", "label"});
                  PolicyPoint point;
                  point.free_range = item.Number("free_range", std::nullopt, Range::Positive());
                  point.v_des = item.Number("v_des", std::nullopt, {0.0, 15.0, false, true});
                  point.label = item.String("label", std::string());
                  p.points.push_back(point);
                }
              },
              [](YAML::Emitter& out, const P& p) {
                out << YAML::Key << "points" << YAML::Value << YAML::BeginSeq;
                for (const PolicyPoint& point : p.points) {
                  out << YAML::Flow << YAML::BeginMap << YAML::Key << "free_range" << YAML::Value
                      << point.free_range << YAML::Key << "v_des" << YAML::Value << point.v_des;
                  if (!point.label.empty()) {
                    out << YAML::Key << "label" << YAML::Value << YAML::DoubleQuoted << point.label;
                  }
                  out << YAML::EndMap;
                }
                out << YAML::EndSeq;
              });
  return fields;
}

double ContextPolicy::VDes(double free_range, const std::string& origin) const {
  Validate(origin);
  const double lo = points.front().free_range;
  const double hi = points.back().free_range;
  if (!(free_range >= lo && free_range <= hi)) {
    throw ConfigError(origin, "free_range",
                      "context " + Num(free_range) + " m lies outside the policy's range [" +
                          Num(lo) + ", " + Num(hi) +
                          "] m of measured free ranges; a policy does not extrapolate: learn it "
                          "from densities that span this context, or clamp the context");
  }
  const auto upper =
      std::lower_bound(points.begin(), points.end(), free_range,
                       [](const PolicyPoint& p, double x) { return p.free_range < x; });
  if (upper == points.begin()) return upper->v_des;
  const PolicyPoint& b = *upper;
  const PolicyPoint& a = *(upper - 1);
  const double w = (free_range - a.free_range) / (b.free_range - a.free_range);
  return a.v_des + w * (b.v_des - a.v_des);
}

double ContextPolicy::Clamp(double free_range) const {
  return std::clamp(free_range, points.front().free_range, points.back().free_range);
}

void ContextPolicy::Validate(const std::string& file) const {
  ContextPolicyFields().Check(*this, file, "policy.");
  if (points.size() < 2) {
    throw ConfigError(
        file, "policy.points",
        "needs at least two points (one per density), got " + std::to_string(points.size()));
  }
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::string key = "policy.points[" + std::to_string(i) + "]";
    if (!(points[i].v_des > 0.0 && points[i].v_des <= 15.0)) {
      throw ConfigError(file, key + ".v_des",
                        "got " + Num(points[i].v_des) + "; expected a v_des in (0, 15] (m/s)");
    }
    if (!(points[i].free_range > 0.0) || !std::isfinite(points[i].free_range)) {
      throw ConfigError(file, key + ".free_range",
                        "got " + Num(points[i].free_range) + "; expected a positive range (m)");
    }
    if (i > 0 && !(points[i].free_range > points[i - 1].free_range)) {
      throw ConfigError(file, key + ".free_range",
                        "free ranges must increase strictly from point to point (" +
                            Num(points[i - 1].free_range) + " then " + Num(points[i].free_range) +
                            ")");
    }
  }
}

ContextPolicy ContextPolicy::FromYaml(const YamlMap& map) {
  ContextPolicy p = ContextPolicyFields().Read(map);
  p.Validate(map.file());
  return p;
}

std::string ContextPolicy::ToYamlString() const {
  YAML::Emitter out;
  ContextPolicyFields().Write(out, *this);
  return std::string(out.c_str()) + "\n";
}

}  // namespace quadtune::engine
