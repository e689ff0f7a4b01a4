#pragma once
/// \file
/// A forward-looking depth camera simulated by analytic ray casting (RayCaster).
///
/// Camera frame C: x forward (optical axis), y left, z up; it sits at p_BC in the body frame,
/// pitched down by `pitch` about y_B. Pixel (col, row) looks along
///   d_C ∝ (1, -(col + ½ - W/2) / f_x, -(row + ½ - H/2) / f_y),  f_x = (W/2) / tan(fov_h/2),
/// i.e. a pinhole camera, row 0 at the top, column 0 at the left. A pixel's range is the
/// Euclidean distance along its ray to the first surface (occlusion respected), returned when it
/// lies in [min_range, max_range].
///
/// Output for a local map: the sensor origin, the world-frame hit points, and the endpoints
/// (at max_range) of rays that hit nothing, so free space can be cleared along them.
///
/// Thread safety: a DepthSensor holds a noise generator and its schedule, so it belongs to one
/// World / thread; scanning only reads the (immutable) RayCaster.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "quadtune/common/fields_fwd.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/physics/ray_caster.hpp"

namespace quadtune::physics {

class World;

/// Configuration of a depth sensor (defaults: a RealSense-D435-like camera at 64×48).
struct DepthSensorOptions {
  int width = 64;                      ///< pixels, [1, 4096]
  int height = 48;                     ///< pixels, [1, 4096]
  double horizontal_fov_deg = 87.0;    ///< (deg), (0, 170]
  double vertical_fov_deg = 58.0;      ///< (deg), (0, 170]
  double min_range = 0.1;              ///< (m), >= 0, < max_range
  double max_range = 5.0;              ///< (m)
  double rate_hz = 15.0;               ///< scans per second of simulated time, > 0
  Eigen::Vector3d p_BC = Eigen::Vector3d::Zero();  ///< camera position in the body frame (m)
  double pitch = 0.0;                  ///< camera pitch down about y_B (rad), [-π/2, π/2]
  double range_noise = 0.0;            ///< std-dev of Gaussian range noise (m), >= 0

  /// Throws ConfigError(origin, key, ...) naming the bad key and its allowed range: the ranges
  /// of DepthSensorFields(), max_range > min_range and a finite p_BC.
  void Validate(const std::string& origin = "") const;
  /// Reads the keys of DepthSensorFields() (p_BC as a 3-vector), then Validate()s; unknown keys
  /// are rejected.
  static DepthSensorOptions FromYaml(const YamlMap& map);
};

/// The keys of a depth sensor options map: reading, writing and the configuration reference.
const Fields<DepthSensorOptions>& DepthSensorFields();

/// One depth image and the points derived from it. Buffers are reused between scans.
struct DepthScan {
  double time = 0.0;                                          ///< simulation time (s)
  Eigen::Vector3d origin_W = Eigen::Vector3d::Zero();         ///< camera centre (m)
  Eigen::Quaterniond q_WC = Eigen::Quaterniond::Identity();   ///< camera attitude
  int width = 0;
  int height = 0;
  /// Range per pixel, row-major (m); +inf where nothing lies within [min_range, max_range].
  std::vector<float> ranges;
  std::vector<Eigen::Vector3d> hits_W;    ///< surface points of the rays that hit (m)
  std::vector<Eigen::Vector3d> misses_W;  ///< max-range endpoints of the rays that did not (m)
};

/// The sensor: fixed ray directions, a schedule at rate_hz and a seeded noise stream.
class DepthSensor {
 public:
  /// Validates `options`; `seed` drives the range noise.
  explicit DepthSensor(const DepthSensorOptions& options = {}, std::uint64_t seed = 0);

  /// Scans from the body pose (p_WB, q_WB) against `caster`, filling `out` (reusing its memory).
  void Scan(const RayCaster& caster, const Eigen::Vector3d& p_WB, const Eigen::Quaterniond& q_WB,
            double time, DepthScan& out);
  /// Scans from the world's true drone pose if a scan is due (time >= next scan time); returns
  /// whether it scanned. The first scan is due at time 0, then every 1 / rate_hz.
  bool Update(const World& world, DepthScan& out);
  /// Restarts the schedule and the noise stream.
  void Reset(std::uint64_t seed);

  /// Unit ray directions in the camera frame, row-major.
  [[nodiscard]] const std::vector<Eigen::Vector3d>& directions_C() const { return directions_C_; }
  [[nodiscard]] const DepthSensorOptions& options() const { return options_; }

 private:
  DepthSensorOptions options_;
  std::vector<Eigen::Vector3d> directions_C_;
  Eigen::Quaterniond q_BC_;
  Rng rng_;
  std::int64_t scans_ = 0;
};

}  // namespace quadtune::physics
