#pragma once
/// \file
/// Static obstacle primitives in the world frame W (z up, ground plane z = 0).
///
/// These plain value types are the contract between the layout generator (which makes them),
/// the physics World (which builds Bullet bodies from them), the depth sensor (which ray-casts
/// them) and the planner metrics (which measure clearance to them).
///
/// Thread safety: values; safe to share read-only between threads.

#include <Eigen/Core>
#include <array>
#include <compare>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"

namespace quadtune::physics {

/// A vertical circular cylinder (a pillar, a tree trunk) standing on z_min.
struct CylinderObstacle {
  Eigen::Vector2d center_W = Eigen::Vector2d::Zero();  ///< axis position in the xy-plane (m)
  double radius = 0.3;                                 ///< (m), > 0
  double z_min = 0.0;                                  ///< bottom face height (m)
  double z_max = 3.0;                                  ///< top face height (m), > z_min

  friend bool operator==(const CylinderObstacle&, const CylinderObstacle&) = default;
};

/// A ring (a torus) standing vertically: its symmetry axis is horizontal, pointing along
/// (cos yaw, sin yaw, 0), so a drone flying along that axis passes through the hole.
struct RingObstacle {
  Eigen::Vector3d center_W = Eigen::Vector3d(0, 0, 1.5);  ///< centre of the hole (m)
  double yaw = 0.0;        ///< heading of the ring's axis from +x about +z (rad)
  double radius = 1.0;     ///< major radius: ring centre to the centre line of the rim (m), > 0
  double thickness = 0.1;  ///< rim thickness: diameter of the rim's circular cross-section (m),
                           ///< 0 < thickness < 2 radius

  /// Unit vector of the ring's symmetry axis (horizontal).
  [[nodiscard]] Eigen::Vector3d Axis_W() const;
  /// Inner radius of the free hole (m): radius - thickness / 2.
  [[nodiscard]] double HoleRadius() const { return radius - 0.5 * thickness; }

  friend bool operator==(const RingObstacle&, const RingObstacle&) = default;
};

/// Every static obstacle of a world.
struct ObstacleSet {
  std::vector<CylinderObstacle> cylinders;
  std::vector<RingObstacle> rings;
  bool ground = true;  ///< a ground plane at z = 0

  [[nodiscard]] std::size_t size() const { return cylinders.size() + rings.size(); }

  /// Signed Euclidean distance (m) from p_W to the nearest obstacle surface, the ground
  /// included when `ground` is set; negative inside an obstacle. O(number of obstacles).
  [[nodiscard]] double Distance(const Eigen::Vector3d& p_W) const;

  /// Throws ConfigError(origin, "<kind>[i].<field>", ...) for a non-finite or out-of-range field.
  void Validate(const std::string& origin = "") const;

  friend bool operator==(const ObstacleSet&, const ObstacleSet&) = default;
};

/// Signed distance (m) from p_W to a cylinder's surface (negative inside).
[[nodiscard]] double SignedDistance(const CylinderObstacle& c, const Eigen::Vector3d& p_W);
/// Signed distance (m) from p_W to a ring's surface (negative inside the rim).
[[nodiscard]] double SignedDistance(const RingObstacle& r, const Eigen::Vector3d& p_W);

/// Which kind of obstacle an ObstacleId refers to.
enum class ObstacleKind {
  kGround,    ///< the ground plane z = 0 (index 0)
  kCylinder,  ///< ObstacleSet::cylinders[index]
  kRing,      ///< ObstacleSet::rings[index]
};
/// Named as the ObstacleSet members (and layout file keys) that hold each kind.
constexpr auto EnumNames(ObstacleKind) {
  return std::array{EnumName{ObstacleKind::kGround, "ground"},
                    EnumName{ObstacleKind::kCylinder, "cylinders"},
                    EnumName{ObstacleKind::kRing, "rings"}};
}

/// Names one obstacle of an ObstacleSet (or the ground). A value type, ordered by (kind, index).
struct ObstacleId {
  ObstacleKind kind = ObstacleKind::kGround;
  int index = 0;

  /// Human-readable form: "ground", "cylinders[3]", "rings[0]".
  [[nodiscard]] std::string ToString() const;

  friend bool operator==(const ObstacleId&, const ObstacleId&) = default;
  friend auto operator<=>(const ObstacleId&, const ObstacleId&) = default;
};

}  // namespace quadtune::physics
