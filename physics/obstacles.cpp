#include "quadtune/physics/obstacles.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::physics {

std::string ObstacleId::ToString() const {
  const std::string name = quadtune::ToString(kind);
  return kind == ObstacleKind::kGround ? name : name + "[" + std::to_string(index) + "]";
}

Eigen::Vector3d RingObstacle::Axis_W() const { return {std::cos(yaw), std::sin(yaw), 0.0}; }

double SignedDistance(const CylinderObstacle& c, const Eigen::Vector3d& p_W) {
  // Distance to a finite cylinder: combine the radial and the axial excess.
  const double radial = (p_W.head<2>() - c.center_W).norm() - c.radius;
  const double z_mid = 0.5 * (c.z_min + c.z_max);
  const double axial = std::abs(p_W.z() - z_mid) - 0.5 * (c.z_max - c.z_min);
  const double outside = std::hypot(std::max(radial, 0.0), std::max(axial, 0.0));
  return outside + std::min(std::max(radial, axial), 0.0);
}

double SignedDistance(const RingObstacle& r, const Eigen::Vector3d& p_W) {
  const Eigen::Vector3d d = p_W - r.center_W;
  const Eigen::Vector3d axis = r.Axis_W();
  const double along = d.dot(axis);                       // along the symmetry axis
  const double in_plane = (d - along * axis).norm();      // distance from the axis
  return std::hypot(in_plane - r.radius, along) - 0.5 * r.thickness;
}

double ObstacleSet::Distance(const Eigen::Vector3d& p_W) const {
  double best = ground ? p_W.z() : std::numeric_limits<double>::infinity();
  for (const auto& c : cylinders) best = std::min(best, SignedDistance(c, p_W));
  for (const auto& r : rings) best = std::min(best, SignedDistance(r, p_W));
  return best;
}

void ObstacleSet::Validate(const std::string& origin) const {
  auto key = [](const char* kind, std::size_t i, const char* field) {
    return std::string(kind) + "[" + std::to_string(i) + "]." + field;
  };
  for (std::size_t i = 0; i < cylinders.size(); ++i) {
    const auto& c = cylinders[i];
    CheckInRange(c.center_W.x(), Range::Any(), origin, key("cylinders", i, "center.x"));
    CheckInRange(c.center_W.y(), Range::Any(), origin, key("cylinders", i, "center.y"));
    CheckInRange(c.radius, Range::Positive(), origin, key("cylinders", i, "radius"));
    CheckInRange(c.z_min, Range::Any(), origin, key("cylinders", i, "z_min"));
    CheckInRange(c.z_max, {c.z_min, std::numeric_limits<double>::infinity(), true, false}, origin,
                 key("cylinders", i, "z_max"));
  }
  for (std::size_t i = 0; i < rings.size(); ++i) {
    const auto& r = rings[i];
    for (int k = 0; k < 3; ++k) {
      CheckInRange(r.center_W[k], Range::Any(), origin, key("rings", i, "center"));
    }
    CheckInRange(r.yaw, Range::Any(), origin, key("rings", i, "yaw"));
    CheckInRange(r.radius, Range::Positive(), origin, key("rings", i, "radius"));
    CheckInRange(r.thickness, {0.0, 2.0 * r.radius, true, true}, origin,
                 key("rings", i, "thickness"));
  }
}

}  // namespace quadtune::physics
