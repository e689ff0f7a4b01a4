#include "quadtune/physics/depth_sensor.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/physics/world.hpp"

namespace quadtune::physics {

const Fields<DepthSensorOptions>& DepthSensorFields() {
  static const Fields<DepthSensorOptions> fields =
      Fields<DepthSensorOptions>()
          .Integer("width", &DepthSensorOptions::width, Range::Closed(1, 4096),
                   "image width (pixels)")
          .Integer("height", &DepthSensorOptions::height, Range::Closed(1, 4096),
                   "image height (pixels)")
          .Number("horizontal_fov_deg", &DepthSensorOptions::horizontal_fov_deg,
                  {0.0, 170.0, true, false}, "horizontal field of view (deg)")
          .Number("vertical_fov_deg", &DepthSensorOptions::vertical_fov_deg,
                  {0.0, 170.0, true, false}, "vertical field of view (deg)")
          .Number("min_range", &DepthSensorOptions::min_range, Range::NonNegative(),
                  "nearest range returned (m); below `max_range`")
          .Number("max_range", &DepthSensorOptions::max_range, Range::Positive(),
                  "farthest range returned (m); rays that hit nothing end there")
          .Number("rate_hz", &DepthSensorOptions::rate_hz, Range::Positive(),
                  "scans per second of simulated time")
          .Vector3("p_BC", &DepthSensorOptions::p_BC, "camera position in the body frame (m)")
          .Number("pitch", &DepthSensorOptions::pitch,
                  Range::Closed(-0.5 * std::numbers::pi, 0.5 * std::numbers::pi),
                  "camera pitch down about the body y-axis (rad)")
          .Number("range_noise", &DepthSensorOptions::range_noise, Range::NonNegative(),
                  "std-dev of Gaussian range noise (m)");
  return fields;
}

void DepthSensorOptions::Validate(const std::string& origin) const {
  DepthSensorFields().Check(*this, origin);
  CheckInRange(max_range, {min_range, std::numeric_limits<double>::infinity(), true, true}, origin,
               "max_range");
  for (int i = 0; i < 3; ++i) {
    CheckInRange(p_BC[i], Range::Any(), origin, "p_BC[" + std::to_string(i) + "]");
  }
}

DepthSensorOptions DepthSensorOptions::FromYaml(const YamlMap& map) {
  const DepthSensorOptions o = DepthSensorFields().Read(map);
  o.Validate(map.file());
  return o;
}

DepthSensor::DepthSensor(const DepthSensorOptions& options, std::uint64_t seed)
    : options_(options) {
  options_.Validate();
  const double deg = std::numbers::pi / 180.0;
  const double fx = 0.5 * options_.width / std::tan(0.5 * options_.horizontal_fov_deg * deg);
  const double fy = 0.5 * options_.height / std::tan(0.5 * options_.vertical_fov_deg * deg);
  directions_C_.reserve(static_cast<std::size_t>(options_.width) * static_cast<std::size_t>(options_.height));
  for (int row = 0; row < options_.height; ++row) {
    for (int col = 0; col < options_.width; ++col) {
      const Eigen::Vector3d d(1.0, -(col + 0.5 - 0.5 * options_.width) / fx,
                              -(row + 0.5 - 0.5 * options_.height) / fy);
      directions_C_.push_back(d.normalized());
    }
  }
  // Pitch down = positive rotation about +y_B (x forward, z up).
  q_BC_ = Eigen::Quaterniond(Eigen::AngleAxisd(options_.pitch, Eigen::Vector3d::UnitY()));
  Reset(seed);
}

void DepthSensor::Reset(std::uint64_t seed) {
  rng_.seed(DeriveSeed(seed, {0x5e45}));
  scans_ = 0;
}

void DepthSensor::Scan(const RayCaster& caster, const Eigen::Vector3d& p_WB,
                       const Eigen::Quaterniond& q_WB, double time, DepthScan& out) {
  const Eigen::Quaterniond q_WC = q_WB * q_BC_;
  const Eigen::Matrix3d R_WC = q_WC.toRotationMatrix();
  const Eigen::Vector3d origin_W = p_WB + q_WB * options_.p_BC;
  out.time = time;
  out.origin_W = origin_W;
  out.q_WC = q_WC;
  out.width = options_.width;
  out.height = options_.height;
  out.ranges.resize(directions_C_.size());
  out.hits_W.clear();
  out.misses_W.clear();
  const double max_range = options_.max_range;
  for (std::size_t i = 0; i < directions_C_.size(); ++i) {
    const Eigen::Vector3d d_W = R_WC * directions_C_[i];
    const RayHit hit = caster.Cast(origin_W, d_W, max_range);
    double range = hit.distance;
    if (hit.hit() && options_.range_noise > 0.0) {
      range = std::max(0.0, range + options_.range_noise * StandardNormal(rng_));
    }
    if (hit.hit() && range >= options_.min_range && range <= max_range) {
      out.ranges[i] = static_cast<float>(range);
      out.hits_W.push_back(origin_W + range * d_W);
    } else {
      out.ranges[i] = std::numeric_limits<float>::infinity();
      if (!hit.hit()) out.misses_W.push_back(origin_W + max_range * d_W);
    }
  }
}

bool DepthSensor::Update(const World& world, DepthScan& out) {
  // The n-th scan is due at n / rate_hz; compare in whole physics steps to avoid drift.
  const double due = static_cast<double>(scans_) / options_.rate_hz;
  const double step = 1.0 / world.options().physics_rate_hz;
  if (world.time() + 0.5 * step < due) return false;
  const DroneState s = world.State();
  Scan(world.ray_caster(), s.p_W, s.q_WB, world.time(), out);
  ++scans_;
  // Skip scans that fell entirely behind (a long Advance between calls).
  while (static_cast<double>(scans_) / options_.rate_hz + 0.5 * step <= world.time()) ++scans_;
  return true;
}

}  // namespace quadtune::physics
