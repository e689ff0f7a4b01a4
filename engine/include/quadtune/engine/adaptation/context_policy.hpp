#pragma once
/// \file
/// What the online adaptation measures about its surroundings and risks with a plan, and the
/// context policy: v_des as a function of a measured context, learned from the density study.
///
/// - **Free range** (the context), of one of two kinds (MeasureFreeRange): `rays`, the mean
///   length of horizontal rays fanned over ±half_angle about a heading (the sensor's cone) up to
///   the first raw-occupied cell or `range`; `disc`, the mean free path of the mapped disc of
///   radius `range`. Dense forests give short free ranges, sparse ones long.
/// - **Stopping risk** J_r of a plan: at every check_dt of the plan, the distance the drone
///   needs to stop from its planned speed |v| at a_max, |v|² / (2 a_max), against the free
///   distance along its planned direction of motion in the inflated map (up to `range`); J_r is
///   the largest squared shortfall, max_t max(0, |v|² / (2 a_max) − d_free)² (m²), plus the
///   clearance-at-speed shortfall of StoppingRisk. A plan that could stop before any obstacle
///   it heads for, with the margin its speed asks for, scores 0.
/// - **ContextPolicy**: points (free range, v_des), one per density of the density study: the
///   density's v_des (by a grid of fixed v_des or the study's tuned point, engine/adaptation/
///   corridor_study.hpp) at the mean free range measured in its forests; v_des between two
///   points is interpolated linearly. A context outside [first, last] is refused
///   (ContextPolicy::VDes throws); the adaptation clamps the measured context to the range and
///   records that it did.
///
/// Thread safety: pure functions and values.

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/fields_fwd.hpp"
#include "quadtune/planning/local_map.hpp"
#include "quadtune/planning/trajectory.hpp"

namespace quadtune::engine {

/// Which free range is measured (see MeasureFreeRange).
enum class FreeRangeKind {
  kRays,  ///< mean length of the rays of a fan over the sensor's cone
  kDisc,  ///< mean free path of the disc of radius `range` about the point
};
constexpr auto EnumNames(FreeRangeKind) {
  return std::array{EnumName{FreeRangeKind::kRays, "rays"},
                    EnumName{FreeRangeKind::kDisc, "disc"}};
}

/// How the free range is measured.
struct FreeRangeOptions {
  FreeRangeKind kind = FreeRangeKind::kRays;  ///< `rays` or `disc`
  double half_angle_deg = 60.0;  ///< half-width of the fan about the heading (deg), (0, 180]
  double range = 5.0;            ///< longest ray, or the disc's radius (m), > 0
  int rays = 25;                 ///< rays in the fan, [1, 1000]

  friend bool operator==(const FreeRangeOptions&, const FreeRangeOptions&) = default;
};

/// The free range (m) at p_W in `map`'s raw occupancy.
/// - `rays`: the mean free-ray length from p_W over the horizontal fan of `rays` rays spanning
///   ±half_angle about `heading_W` (its horizontal part; +x when it has none), each at most
///   `range` long.
/// - `disc`: the mean free path of the horizontal disc of radius `range` centred at p_W, in the
///   map layer that holds p_W: π A_free / (2 n res), A_free the disc's free area and n its
///   raw-occupied cells of side res (the obstacle outline the sensor has seen, about n res of
///   perimeter; for a field of convex obstacles the mean chord of the free space is
///   π A_free / perimeter, and the sensor sees about half of each outline), at most 10 range
///   (no obstacle seen). It counts everything mapped around p_W, behind the drone as well, so
///   it separates densities more than the rays do (which mostly run to the sensor's range
///   between obstacles) and lags behind a change of density by up to `range`. `heading_W`,
///   half_angle_deg and rays are unused.
[[nodiscard]] double MeasureFreeRange(const planning::LocalMap& map, const Eigen::Vector3d& p_W,
                                      const Eigen::Vector3d& heading_W,
                                      const FreeRangeOptions& options);

/// J_r of `trajectory` (see the file comment), sampled every `check_dt` (s); free distances are
/// searched up to `range` (m) in the inflated map. With `reaction_time` τ > 0 it adds the
/// clearance at speed: max_t max(0, τ |v| − (c_raw − inflation))², c_raw the distance to the
/// nearest raw-occupied cell (searched up to 2 m), so a plan must keep a margin beyond the
/// drone's safety radius that grows with its speed. 0 for an empty trajectory.
[[nodiscard]] double StoppingRisk(const planning::Trajectory& trajectory,
                                  const planning::LocalMap& map, double a_max, double range,
                                  double reaction_time = 0.0, double inflation = 0.0,
                                  double check_dt = 0.1);

/// One point of a ContextPolicy.
struct PolicyPoint {
  double free_range = 0.0;  ///< measured context (m)
  double v_des = 0.0;       ///< v_des flown there (m/s)
  std::string label;        ///< where it came from (e.g. the density's label); may be empty

  friend bool operator==(const PolicyPoint&, const PolicyPoint&) = default;
};

/// v_des as a function of the measured free range (see the file comment).
///
/// YAML (`policy:` of an adaptation experiment, or a file written by `quadtune policy`):
/// ```
/// free_range: {half_angle_deg: 60, range: 5, rays: 25}
/// points:
///   - {free_range: 2.1, v_des: 2.4, label: "0.9"}
///   - {free_range: 4.3, v_des: 5.1, label: "3.0"}
/// ```
struct ContextPolicy {
  FreeRangeOptions measure;         ///< how the context is measured
  std::vector<PolicyPoint> points;  ///< at least two, strictly increasing free_range

  /// v_des at `free_range` (linear between neighbouring points). Throws ConfigError(origin,
  /// "free_range", ...) naming the value and the policy's range when it lies outside it.
  [[nodiscard]] double VDes(double free_range, const std::string& origin = "policy") const;
  /// `free_range` clamped into [first, last].
  [[nodiscard]] double Clamp(double free_range) const;
  /// Throws ConfigError(file, "policy.<key>", ...) for the first bad field: fewer than two
  /// points, free ranges not strictly increasing, a v_des outside (0, 15].
  void Validate(const std::string& file = "") const;
  /// Reads ContextPolicyFields over the defaults, then validates; unknown keys throw.
  static ContextPolicy FromYaml(const YamlMap& map);
  /// Writes the YAML form.
  [[nodiscard]] std::string ToYamlString() const;

  friend bool operator==(const ContextPolicy&, const ContextPolicy&) = default;
};

/// `free_range:` of a policy: kind, half_angle_deg, range, rays.
const Fields<FreeRangeOptions>& FreeRangeFields();

/// `policy:`: free_range (FreeRangeOptions) and points.
const Fields<ContextPolicy>& ContextPolicyFields();

}  // namespace quadtune::engine
