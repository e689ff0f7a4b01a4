#pragma once
/// \file
/// The Bullet quadrotor world: static obstacles, an optional ground plane and one quadrotor
/// flown by the geometric controller, with wind, noise and model mismatch for "high-fidelity"
/// runs.
///
/// Each World owns its Bullet dynamics world together with its own collision configuration
/// (small pools, WorldOptions::collision_pool_size), dispatcher, broadphase and solver; nothing
/// process-global is set. Obstacles are static btCollisionObjects: cylinders are
/// btCylinderShapeZ, rings a compound of capsules whose centre lines form a regular polygon
/// around the rim, sized so the rim surface deviates from the exact torus by at most
/// WorldOptions::ring_max_error. The drone is a btRigidBody (sphere or box) with continuous
/// collision detection; at the default 1000 Hz and the drone's max_speed a step moves it far
/// less than its own radius, so it cannot tunnel through a thin rim.
///
/// Per physics step (1 / physics_rate_hz): the controller runs when due (every
/// physics_rate_hz / controller_rate_hz steps) on MeasuredState(); the motors approach the command
/// with the first-order lag; thrust, rotor torques, the gyroscopic torque, linear drag against
/// the air (wind and gusts included) and the optional force noise are applied; Bullet steps; the
/// collision monitor records contacts. The gyroscopic torque -ω_B × (J ω_B) is computed in double
/// precision from the true inertia (DroneDescription::inertia × WorldOptions::mass_scale) at the
/// midpoint estimate of the body rate over the step (so the rate follows Euler's equations to
/// second order in the step); Bullet's own gyroscopic term is switched off on the drone (it is
/// single precision and vanishes for inertias with det J below float epsilon).
///
/// Thread safety: a World is owned by one thread at a time; distinct Worlds may step
/// concurrently on different threads and give bit-identical results for the same inputs.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/fields_fwd.hpp"
#include "quadtune/physics/collision_monitor.hpp"
#include "quadtune/physics/controller.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/obstacles.hpp"
#include "quadtune/physics/quadrotor.hpp"
#include "quadtune/physics/ray_caster.hpp"

class btDiscreteDynamicsWorld;
class btRigidBody;
class btCollisionShape;
class btTransform;

namespace quadtune::physics {

/// What a contact does to the drone.
enum class CollisionResponse {
  kPhysical,     ///< Bullet resolves contacts: the drone bounces off / rests on obstacles
  kPassThrough,  ///< contacts are detected and counted, but the drone flies on unhindered
};
constexpr auto EnumNames(CollisionResponse) {
  return std::array{EnumName{CollisionResponse::kPhysical, "physical"},
                    EnumName{CollisionResponse::kPassThrough, "pass_through"}};
}

/// Standard deviations of the noise added to the state the controller sees (MeasuredState()).
struct MeasurementNoise {
  double position = 0.0;          ///< (m), per axis
  double velocity = 0.0;          ///< (m/s), per axis
  double attitude = 0.0;          ///< (rad), per axis of a small rotation applied to q_WB
  double angular_velocity = 0.0;  ///< (rad/s), per body axis

  friend bool operator==(const MeasurementNoise&, const MeasurementNoise&) = default;
};

/// Configuration of a World. Plain values; defaults give an ideal, noise-free world.
struct WorldOptions {
  double physics_rate_hz = 1000.0;    ///< Bullet and motor integration rate (Hz), [100, 20000]
  double controller_rate_hz = 500.0;  ///< controller rate (Hz); must divide physics_rate_hz
  double gravity = kGravity;          ///< (m/s²), > 0, along -z_W
  CollisionResponse collision_response = CollisionResponse::kPhysical;
  double contact_release_time = 0.3;  ///< see CollisionMonitor (s), >= 0: a bounce and re-contact
                                      ///< within this time is one episode (one crash)
  int collision_pool_size = 64;       ///< Bullet manifold / algorithm pool entries, [8, 4096]
  double ring_max_error = 0.004;      ///< max deviation of the capsule ring from the torus (m)
  double obstacle_margin = 0.002;     ///< Bullet collision margin of cylinders (m), > 0

  Eigen::Vector3d wind_W = Eigen::Vector3d::Zero();  ///< constant wind velocity (m/s)
  double gust_stddev = 0.0;         ///< stationary std-dev of each gust component (m/s), >= 0
  double gust_time_constant = 2.0;  ///< Ornstein–Uhlenbeck correlation time of gusts (s), > 0
  double force_noise = 0.0;         ///< std-dev of a white force disturbance per axis (N), >= 0
  double torque_noise = 0.0;        ///< std-dev of a white torque disturbance per axis (N·m)
  MeasurementNoise measurement_noise;
  double mass_scale = 1.0;  ///< true mass / described mass (model mismatch), (0.2, 5)
  bool motor_lag = true;    ///< false: rotors reach commanded speeds instantly
  std::uint64_t seed = 0;   ///< seed of every random stream of the world

  /// Throws ConfigError(origin, key_prefix + key, ...) naming the bad key and its allowed range:
  /// the ranges of WorldFields(), then controller_rate_hz in (0, physics_rate_hz] dividing it
  /// into whole physics steps, and a finite wind.
  void Validate(const std::string& origin = "", const std::string& key_prefix = "") const;
  /// Reads the keys of WorldFields() (measurement_noise a nested map, wind a 3-vector), then
  /// Validate()s. Unknown keys and bad values throw ConfigError naming the file and key.
  static WorldOptions FromYaml(const YamlMap& map);

  friend bool operator==(const WorldOptions&, const WorldOptions&) = default;
};

/// The keys of a `measurement_noise` map (std-devs).
const Fields<MeasurementNoise>& MeasurementNoiseFields();
/// The keys of a world options map: reading, writing and the configuration reference.
const Fields<WorldOptions>& WorldFields();

/// Immutable Bullet collision shapes and the analytic ray caster for one ObstacleSet. Worlds
/// that fly the same layout share one ObstacleGeometry (each World keeps only its own light
/// static collision objects), which cuts memory per world and the cost of a Reset to a layout
/// already built. Cylinders are btCylinderShapeZ; a ring is a compound of capsules along a
/// regular polygon (see WorldOptions::ring_max_error); the ground is a plane.
///
/// Thread safety: immutable after construction; share it read-only between Worlds and threads
/// (Bullet only reads collision shapes while it simulates and casts rays).
class ObstacleGeometry {
 public:
  /// Builds the shapes. Throws ConfigError for an invalid set, ring_max_error outside (0, 0.05]
  /// or obstacle_margin outside (0, 0.05] (m).
  ObstacleGeometry(const ObstacleSet& obstacles, double ring_max_error, double obstacle_margin);
  ~ObstacleGeometry();
  ObstacleGeometry(const ObstacleGeometry&) = delete;
  ObstacleGeometry& operator=(const ObstacleGeometry&) = delete;

  /// Shorthand using options.ring_max_error and options.obstacle_margin.
  static std::shared_ptr<const ObstacleGeometry> Make(const ObstacleSet& obstacles,
                                                      const WorldOptions& options);

  /// One static obstacle: a shape owned by the geometry, its pose, and which obstacle it is.
  struct Entry;
  [[nodiscard]] const std::vector<Entry>& entries() const;

  [[nodiscard]] const ObstacleSet& obstacles() const { return obstacles_; }
  [[nodiscard]] const RayCaster& ray_caster() const { return caster_; }
  [[nodiscard]] double ring_max_error() const { return ring_max_error_; }
  [[nodiscard]] double obstacle_margin() const { return obstacle_margin_; }

 private:
  struct Data;
  ObstacleSet obstacles_;
  double ring_max_error_;
  double obstacle_margin_;
  RayCaster caster_;
  std::unique_ptr<Data> data_;
};

/// Which component decides the rotor commands.
enum class ControlMode {
  kTracking,     ///< the geometric controller follows the reference
  kRotorSpeeds,  ///< rotor speeds commanded directly (clamped to the rotor limits)
  kMotorsOff,    ///< motors unpowered: command 0 rpm (they spin down with the motor lag)
};
constexpr auto EnumNames(ControlMode) {
  return std::array{EnumName{ControlMode::kTracking, "tracking"},
                    EnumName{ControlMode::kRotorSpeeds, "rotor_speeds"},
                    EnumName{ControlMode::kMotorsOff, "motors_off"}};
}

/// A simulated quadrotor among static obstacles. Non-copyable; movable.
class World {
 public:
  /// Builds the world; `initial` is the drone's state at time 0 (see DroneState::Hover). The
  /// reference starts as "hold the initial position and heading". Validates all inputs.
  World(const ObstacleSet& obstacles, const DroneDescription& drone,
        const WorldOptions& options = {}, const DroneState& initial = {});
  ~World();
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  /// Builds the world on a shared, pre-built obstacle geometry (its ring_max_error and
  /// obstacle_margin replace those of `options`).
  World(std::shared_ptr<const ObstacleGeometry> geometry, const DroneDescription& drone,
        const WorldOptions& options = {}, const DroneState& initial = {});
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  /// Re-uses this world for a new flight: new obstacles (shapes, objects and the ray caster are
  /// rebuilt only when they differ from the current ones), drone, options and initial
  /// state. Time, collisions, random streams and the reference restart. The result is
  /// bit-identical to a freshly constructed World with the same arguments.
  void Reset(const ObstacleSet& obstacles, const DroneDescription& drone,
             const WorldOptions& options, const DroneState& initial);
  /// Same on a shared obstacle geometry; the static objects are rebuilt only when the geometry
  /// differs from the current one.
  void Reset(std::shared_ptr<const ObstacleGeometry> geometry, const DroneDescription& drone,
             const WorldOptions& options, const DroneState& initial);
  /// Restarts with the same obstacles, drone and options from `initial`; `seed` replaces
  /// options().seed when given.
  void Reset(const DroneState& initial, std::optional<std::uint64_t> seed = std::nullopt);

  /// Sets a constant reference and switches to ControlMode::kTracking.
  void SetReference(const TrackingReference& reference);
  /// Sets a time-varying reference, evaluated at every controller update with the simulation
  /// time (s), and switches to ControlMode::kTracking.
  void SetReference(std::function<TrackingReference(double time)> reference);
  /// Commands rotor speeds (rpm) directly, bypassing the controller.
  void CommandRotorSpeeds(const RotorSpeeds& speeds);
  /// Cuts motor power: rotors spin down to 0 rpm with the motor lag (free fall).
  void StopMotors();

  /// Simulates `seconds` (>= 0) of flight, rounded to whole physics steps; the step count is
  /// kept as an integer so repeated calls never drift.
  void Advance(double seconds);
  /// Simulates exactly one physics step.
  void Step();

  /// True state of the drone (p_W, v_W, q_WB, omega_B, rotor speeds).
  [[nodiscard]] DroneState State() const;
  /// The state the controller last saw: State() plus seeded measurement noise, sampled at the
  /// controller rate (the true state when measurement noise is off).
  [[nodiscard]] const DroneState& MeasuredState() const;
  /// Simulation time (s).
  [[nodiscard]] double time() const;
  /// Number of physics steps since the last reset.
  [[nodiscard]] std::int64_t step_count() const;
  /// Wind velocity (m/s, W) acting now: constant part plus gust.
  [[nodiscard]] Eigen::Vector3d Wind_W() const;
  /// Output of the latest controller update.
  [[nodiscard]] const ControlOutput& LastControl() const;
  [[nodiscard]] ControlMode control_mode() const;
  /// True when the state became non-finite or left a 10 km box (a diverged simulation).
  [[nodiscard]] bool HasDiverged() const;

  [[nodiscard]] const CollisionMonitor& collisions() const;
  [[nodiscard]] const ObstacleSet& obstacles() const;
  /// The (possibly shared) obstacle geometry of this world.
  [[nodiscard]] const std::shared_ptr<const ObstacleGeometry>& geometry() const;
  [[nodiscard]] const DroneDescription& drone() const;
  [[nodiscard]] const WorldOptions& options() const;
  /// Analytic ray caster over obstacles() (for depth sensors); rebuilt on Reset when needed.
  [[nodiscard]] const RayCaster& ray_caster() const;

  /// First hit of Bullet's own rayTest from `from_W` to `to_W` against the static obstacles
  /// (the drone excluded): distance (m) from from_W, or nullopt. For verification; slow.
  [[nodiscard]] std::optional<double> BulletRayDistance(const Eigen::Vector3d& from_W,
                                                        const Eigen::Vector3d& to_W) const;

  /// The underlying Bullet objects, for benchmarks and tests. Changing them voids guarantees.
  [[nodiscard]] btDiscreteDynamicsWorld& bullet_world();
  [[nodiscard]] btRigidBody& bullet_body();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace quadtune::physics
