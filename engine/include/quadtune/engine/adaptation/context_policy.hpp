#pragma once
/// \file
/// What the online adaptation measures about its surroundings and risks with a plan, and the
/// context policy: v_des as a function of a measured context, learned from the density study.
///
/// - **Free range** (the context): from a point at flight height, horizontal rays fanned over
///   ±half_angle about a heading (the sensor's cone) run through the local map's raw occupancy
///   until the first occupied cell or `range`; the free range is their mean length (m). Dense
///   forests give short free ranges, sparse ones long.
/// - **Stopping risk** J_r of a plan: at every check_dt of the plan, the distance the drone
///   needs to stop from its planned speed |v| at a_max, |v|² / (2 a_max), against the free
///   distance along its planned direction of motion in the inflated map (up to `range`); J_r is
///   the largest squared shortfall, max_t max(0, |v|² / (2 a_max) − d_free)² (m²), plus the
///   clearance-at-speed shortfall of StoppingRisk. A plan that could stop before any obstacle
///   it heads for, with the margin its speed asks for, scores 0.
/// - **ContextPolicy**: points (free range, v_des), the tuned v_des of each density of the
///   density study at the mean free range measured in that density's forests; v_des between
///   two points is interpolated linearly. A context outside [first, last] is refused
///   (ContextPolicy::VDes throws); the adaptation clamps the measured context to the range and
///   records that it did.
///
/// Thread safety: pure functions and values.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "quadtune/common/fields_fwd.hpp"
#include "quadtune/planning/local_map.hpp"
#include "quadtune/planning/trajectory.hpp"

namespace quadtune::engine {

/// How the free range is measured.
struct FreeRangeOptions {
  double half_angle_deg = 60.0;  ///< half-width of the fan about the heading (deg), (0, 180]
  double range = 5.0;            ///< longest ray (m), > 0: the sensor's range
  int rays = 25;                 ///< rays in the fan, [1, 1000]

  friend bool operator==(const FreeRangeOptions&, const FreeRangeOptions&) = default;
};

/// Mean free-ray length (m) from p_W over the horizontal fan about `heading_W` (its horizontal
/// part; +x when it has none), in `map`'s raw occupancy.
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

/// `policy:`: free_range (FreeRangeOptions) and points.
const Fields<ContextPolicy>& ContextPolicyFields();

}  // namespace quadtune::engine
