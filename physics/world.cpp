#include "quadtune/physics/world.hpp"

#include <BulletCollision/NarrowPhaseCollision/btRaycastCallback.h>
#include <btBulletDynamicsCommon.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "quadtune/common/error.hpp"
#include "quadtune/common/fields.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::physics {
namespace {

btVector3 ToBt(const Eigen::Vector3d& v) {
  return {static_cast<btScalar>(v.x()), static_cast<btScalar>(v.y()), static_cast<btScalar>(v.z())};
}
Eigen::Vector3d ToEigen(const btVector3& v) {
  return {static_cast<double>(v.x()), static_cast<double>(v.y()), static_cast<double>(v.z())};
}
btMatrix3x3 ColumnsToBt(const Eigen::Vector3d& x, const Eigen::Vector3d& y, const Eigen::Vector3d& z) {
  const auto s = [](double v) { return static_cast<btScalar>(v); };
  return {s(x.x()), s(y.x()), s(z.x()), s(x.y()), s(y.y()), s(z.y()), s(x.z()), s(y.z()), s(z.z())};
}
Eigen::Vector3d NormalVector(Rng& rng) {
  const double x = StandardNormal(rng);
  const double y = StandardNormal(rng);
  const double z = StandardNormal(rng);
  return {x, y, z};
}

// Obstacle identity is stored in Bullet's user indices: index in userIndex, kind in userIndex2.
void Tag(btCollisionObject& object, ObstacleKind kind, int index) {
  object.setUserIndex(index);
  object.setUserIndex2(static_cast<int>(kind));
}

}  // namespace

const Fields<MeasurementNoise>& MeasurementNoiseFields() {
  static const Fields<MeasurementNoise> fields =
      Fields<MeasurementNoise>()
          .Number("position", &MeasurementNoise::position, Range::NonNegative(),
                  "std-dev of the position noise per axis (m)")
          .Number("velocity", &MeasurementNoise::velocity, Range::NonNegative(),
                  "std-dev of the velocity noise per axis (m/s)")
          .Number("attitude", &MeasurementNoise::attitude, Range::NonNegative(),
                  "std-dev per axis of a small rotation applied to the attitude (rad)")
          .Number("angular_velocity", &MeasurementNoise::angular_velocity, Range::NonNegative(),
                  "std-dev of the body-rate noise per body axis (rad/s)");
  return fields;
}

const Fields<WorldOptions>& WorldFields() {
  static const Fields<WorldOptions> fields =
      Fields<WorldOptions>()
          .Number("physics_rate_hz", &WorldOptions::physics_rate_hz, Range::Closed(100.0, 20000.0),
                  "Bullet and motor integration rate (Hz)")
          .Number("controller_rate_hz", &WorldOptions::controller_rate_hz, Range::Positive(),
                  "controller rate (Hz); at most `physics_rate_hz`, which it must divide into a "
                  "whole number of physics steps")
          .Number("gravity", &WorldOptions::gravity, Range::Positive(), "gravity along −z (m/s²)")
          .Choice("collision_response", &WorldOptions::collision_response,
                  "what a contact does: `physical` (Bullet resolves it) or `pass_through` "
                  "(contacts counted, the drone flies on); experiments force `pass_through`")
          .Number("contact_release_time", &WorldOptions::contact_release_time, Range::NonNegative(),
                  "a bounce and re-contact within it is one collision episode (s)")
          .Integer("collision_pool_size", &WorldOptions::collision_pool_size,
                   Range::Closed(8, 4096), "Bullet manifold pool entries")
          .Number("ring_max_error", &WorldOptions::ring_max_error, {0.0, 0.05, true, false},
                  "deviation of the capsule ring from the torus (m)")
          .Number("obstacle_margin", &WorldOptions::obstacle_margin, {0.0, 0.05, true, false},
                  "Bullet collision margin of cylinders (m)")
          .Vector3("wind", &WorldOptions::wind_W, "constant wind (m/s)")
          .Number("gust_stddev", &WorldOptions::gust_stddev, Range::NonNegative(),
                  "stationary std-dev of each gust component (m/s)")
          .Number("gust_time_constant", &WorldOptions::gust_time_constant, Range::Positive(),
                  "Ornstein–Uhlenbeck correlation time of gusts (s)")
          .Number("force_noise", &WorldOptions::force_noise, Range::NonNegative(),
                  "std-dev of a white force disturbance per axis (N)")
          .Number("torque_noise", &WorldOptions::torque_noise, Range::NonNegative(),
                  "std-dev of a white torque disturbance per axis (N·m)")
          .Nested("measurement_noise", &WorldOptions::measurement_noise, MeasurementNoiseFields(),
                  "noise on the state the controller sees (std-devs; see World: "
                  "measurement_noise)")
          .Number("mass_scale", &WorldOptions::mass_scale, Range::Closed(0.2, 5.0),
                  "true mass / described mass (model mismatch)")
          .Flag("motor_lag", &WorldOptions::motor_lag,
                "false: rotors reach commanded speeds at once")
          .Integer("seed", &WorldOptions::seed, Range::NonNegative(),
                   "seed of every random stream of the world");
  return fields;
}

void WorldOptions::Validate(const std::string& origin, const std::string& key_prefix) const {
  WorldFields().Check(*this, origin, key_prefix);
  CheckInRange(controller_rate_hz, {0.0, physics_rate_hz, true, false}, origin,
               key_prefix + "controller_rate_hz");
  const double ratio = physics_rate_hz / controller_rate_hz;
  if (std::abs(ratio - std::round(ratio)) > 1e-9 * ratio) {
    throw ConfigError(origin, key_prefix + "controller_rate_hz",
                      "must divide physics_rate_hz (" + std::to_string(physics_rate_hz) +
                          " Hz) into a whole number of physics steps");
  }
  for (int i = 0; i < 3; ++i) {
    CheckInRange(wind_W[i], Range::Any(), origin, key_prefix + "wind[" + std::to_string(i) + "]");
  }
}

WorldOptions WorldOptions::FromYaml(const YamlMap& map) {
  const WorldOptions o = WorldFields().Read(map);
  o.Validate(map.file(), map.path().empty() ? "" : map.path() + ".");
  return o;
}

struct ObstacleGeometry::Entry {
  btCollisionShape* shape;
  btTransform pose;
  ObstacleId id;
};

struct ObstacleGeometry::Data {
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<Entry> entries;

  void Add(std::unique_ptr<btCollisionShape> shape, const btTransform& pose, ObstacleKind kind,
           int index) {
    entries.push_back({shape.get(), pose, {kind, index}});
    shapes.push_back(std::move(shape));
  }
};

ObstacleGeometry::ObstacleGeometry(const ObstacleSet& obstacles, double ring_max_error,
                                   double obstacle_margin)
    : obstacles_(obstacles),
      ring_max_error_(ring_max_error),
      obstacle_margin_(obstacle_margin),
      caster_(obstacles),
      data_(std::make_unique<Data>()) {
  obstacles_.Validate();
  CheckInRange(ring_max_error, {0.0, 0.05, true, false}, "", "ring_max_error");
  CheckInRange(obstacle_margin, {0.0, 0.05, true, false}, "", "obstacle_margin");
  Data& data = *data_;
  const auto margin = static_cast<btScalar>(obstacle_margin);
  for (std::size_t i = 0; i < obstacles_.cylinders.size(); ++i) {
    const CylinderObstacle& c = obstacles_.cylinders[i];
    const double half_h = 0.5 * (c.z_max - c.z_min);
    auto shape = std::make_unique<btCylinderShapeZ>(
        btVector3(static_cast<btScalar>(c.radius), static_cast<btScalar>(c.radius),
                  static_cast<btScalar>(half_h)));
    shape->setMargin(std::min(margin, static_cast<btScalar>(0.5 * std::min(c.radius, half_h))));
    btTransform pose;
    pose.setIdentity();
    pose.setOrigin(btVector3(static_cast<btScalar>(c.center_W.x()),
                             static_cast<btScalar>(c.center_W.y()),
                             static_cast<btScalar>(0.5 * (c.z_min + c.z_max))));
    data.Add(std::move(shape), pose, ObstacleKind::kCylinder, static_cast<int>(i));
  }
  for (std::size_t i = 0; i < obstacles_.rings.size(); ++i) {
    const RingObstacle& r = obstacles_.rings[i];
    // Capsules along the edges of a regular N-gon of circumradius R_c: the rim's centre line
    // lies between R_c cos(π/N) (edge middles) and R_c (corners); R_c is chosen so that both
    // deviate from the torus' R by the same amount, R tan²(π/2N) <= ring_max_error.
    const double half_angle_max = std::atan(std::sqrt(ring_max_error / r.radius));
    const int n = std::max(8, static_cast<int>(std::ceil(0.5 * std::numbers::pi / half_angle_max)));
    const double half = std::numbers::pi / n;
    const double r_c = 2.0 * r.radius / (1.0 + std::cos(half));
    const double chord = 2.0 * r_c * std::sin(half);
    auto capsule = std::make_unique<btCapsuleShapeX>(static_cast<btScalar>(0.5 * r.thickness),
                                                     static_cast<btScalar>(chord));
    auto compound = std::make_unique<btCompoundShape>(/*enableDynamicAabbTree=*/false, n);
    for (int k = 0; k < n; ++k) {
      const double phi = (2.0 * k + 1.0) * half;
      const Eigen::Vector3d radial(std::cos(phi), std::sin(phi), 0.0);
      const Eigen::Vector3d tangent(-std::sin(phi), std::cos(phi), 0.0);
      btTransform child(ColumnsToBt(tangent, -radial, Eigen::Vector3d::UnitZ()),
                        ToBt(r_c * std::cos(half) * radial));
      compound->addChildShape(child, capsule.get());
    }
    const Eigen::Vector3d axis = r.Axis_W();
    const Eigen::Vector3d u(-axis.y(), axis.x(), 0.0);
    btTransform pose(ColumnsToBt(u, Eigen::Vector3d::UnitZ(), axis), ToBt(r.center_W));
    data.shapes.push_back(std::move(capsule));
    data.Add(std::move(compound), pose, ObstacleKind::kRing, static_cast<int>(i));
  }
  if (obstacles_.ground) {
    auto plane = std::make_unique<btStaticPlaneShape>(btVector3(0, 0, 1), btScalar(0));
    btTransform pose;
    pose.setIdentity();
    data.Add(std::move(plane), pose, ObstacleKind::kGround, 0);
  }
}

ObstacleGeometry::~ObstacleGeometry() = default;

const std::vector<ObstacleGeometry::Entry>& ObstacleGeometry::entries() const {
  return data_->entries;
}

std::shared_ptr<const ObstacleGeometry> ObstacleGeometry::Make(const ObstacleSet& obstacles,
                                                               const WorldOptions& options) {
  return std::make_shared<const ObstacleGeometry>(obstacles, options.ring_max_error,
                                                  options.obstacle_margin);
}

struct World::Impl {
  // Inputs.
  DroneDescription drone;
  WorldOptions options;

  // Bullet core (declaration order = construction order; destroyed explicitly in ~Impl).
  std::unique_ptr<btDefaultCollisionConfiguration> configuration;
  std::unique_ptr<btCollisionDispatcher> dispatcher;
  std::unique_ptr<btDbvtBroadphase> broadphase;
  std::unique_ptr<btSequentialImpulseConstraintSolver> solver;
  std::unique_ptr<btDiscreteDynamicsWorld> world;
  int built_pool_size = 0;

  // Static obstacles (kept across resets when unchanged).
  std::shared_ptr<const ObstacleGeometry> geometry;
  const ObstacleGeometry* built_geometry = nullptr;  // geometry of obstacle_objects
  std::vector<std::unique_ptr<btCollisionObject>> obstacle_objects;

  // The drone.
  std::unique_ptr<btCollisionShape> drone_shape;
  std::unique_ptr<btRigidBody> body;
  Eigen::Vector3d body_inertia = Eigen::Vector3d::Zero();  // principal inertia (kg·m²)
  std::unique_ptr<GeometricController> controller;
  std::unique_ptr<Mixer> plant_mixer;
  std::unique_ptr<MotorModel> motors;

  // Simulation state.
  double dt = 1e-3;
  std::int64_t control_every = 1;
  std::int64_t steps = 0;
  double requested_time = 0.0;  // sum of Advance() requests since the reset (s)
  RotorSpeeds rotor_speeds{};
  RotorSpeeds rotor_command{};
  RotorSpeeds user_command{};
  ControlMode mode = ControlMode::kTracking;
  TrackingReference reference;
  std::function<TrackingReference(double)> reference_fn;
  ControlOutput last_control;
  DroneState measured;
  CollisionMonitor monitor;
  Rng force_rng, measure_rng, gust_rng;
  Eigen::Vector3d gust_W = Eigen::Vector3d::Zero();
  double gust_decay = 1.0;
  double gust_innovation = 0.0;
  std::vector<ObstacleId> contacts;

  ~Impl() { TearDown(); }

  void TearDown() {
    if (world) {
      if (body) world->removeRigidBody(body.get());
      for (auto& object : obstacle_objects) world->removeCollisionObject(object.get());
    }
    body.reset();
    drone_shape.reset();
    world.reset();
    solver.reset();
    broadphase.reset();
    dispatcher.reset();
    configuration.reset();
    obstacle_objects.clear();
    built_geometry = nullptr;
  }

  void BuildCore(int pool_size) {
    btDefaultCollisionConstructionInfo info;
    info.m_defaultMaxPersistentManifoldPoolSize = pool_size;
    info.m_defaultMaxCollisionAlgorithmPoolSize = pool_size;
    configuration = std::make_unique<btDefaultCollisionConfiguration>(info);
    dispatcher = std::make_unique<btCollisionDispatcher>(configuration.get());
    broadphase = std::make_unique<btDbvtBroadphase>();
    solver = std::make_unique<btSequentialImpulseConstraintSolver>();
    world = std::make_unique<btDiscreteDynamicsWorld>(dispatcher.get(), broadphase.get(),
                                                      solver.get(), configuration.get());
    // Static obstacles never move: do not recompute their bounding boxes every step.
    world->setForceUpdateAllAabbs(false);
    built_pool_size = pool_size;
  }

  // Per-world static collision objects referring to the shared geometry's shapes.
  void BuildObstacleObjects() {
    obstacle_objects.clear();
    for (const ObstacleGeometry::Entry& e : geometry->entries()) {
      auto object = std::make_unique<btCollisionObject>();
      object->setCollisionShape(e.shape);
      object->setWorldTransform(e.pose);
      object->setCollisionFlags(btCollisionObject::CF_STATIC_OBJECT);
      // Static obstacles never move: asleep, Bullet skips their AABB update every step (with
      // setForceUpdateAllAabbs(false) it still updates every object that is "active").
      object->setActivationState(ISLAND_SLEEPING);
      object->setFriction(0.5f);
      object->setRestitution(0.0f);
      Tag(*object, e.id.kind, e.id.index);
      obstacle_objects.push_back(std::move(object));
    }
    built_geometry = geometry.get();
  }

  void BuildDrone(const DroneState& initial) {
    if (drone.collision_shape == CollisionShapeKind::kSphere) {
      drone_shape = std::make_unique<btSphereShape>(static_cast<btScalar>(drone.collision_radius));
    } else {
      drone_shape = std::make_unique<btBoxShape>(ToBt(drone.collision_half_extents));
    }
    const double mass = drone.mass * options.mass_scale;
    const Eigen::Vector3d inertia = drone.inertia * options.mass_scale;
    btRigidBody::btRigidBodyConstructionInfo info(static_cast<btScalar>(mass), nullptr,
                                                  drone_shape.get(), ToBt(inertia));
    info.m_linearDamping = 0;
    info.m_angularDamping = 0;
    info.m_friction = 0.5f;
    info.m_restitution = 0.0f;
    const Eigen::Quaterniond q = initial.q_WB.normalized();
    info.m_startWorldTransform =
        btTransform(btQuaternion(static_cast<btScalar>(q.x()), static_cast<btScalar>(q.y()),
                                 static_cast<btScalar>(q.z()), static_cast<btScalar>(q.w())),
                    ToBt(initial.p_W));
    body = std::make_unique<btRigidBody>(info);
    body->setLinearVelocity(ToBt(initial.v_W));
    body->setAngularVelocity(ToBt(q * initial.omega_B));
    body->setActivationState(DISABLE_DEACTIVATION);
    // Step() applies the gyroscopic torque itself (Bullet's implicit term is single precision
    // and vanishes when det J is below float epsilon, as it is for every small drone).
    body->setFlags(body->getFlags() & ~(BT_ENABLE_GYROSCOPIC_FORCE_EXPLICIT |
                                        BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_WORLD |
                                        BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY));
    body_inertia = inertia;
    const double inscribed = drone.InscribedRadius();
    body->setCcdMotionThreshold(static_cast<btScalar>(0.5 * inscribed));
    body->setCcdSweptSphereRadius(static_cast<btScalar>(0.9 * inscribed));
    if (options.collision_response == CollisionResponse::kPassThrough) {
      body->setCollisionFlags(body->getCollisionFlags() | btCollisionObject::CF_NO_CONTACT_RESPONSE);
    }
  }

  void Reset(std::shared_ptr<const ObstacleGeometry> new_geometry, const DroneDescription& new_drone,
             const WorldOptions& new_options, const DroneState& initial) {
    QT_DEMAND(new_geometry != nullptr, "obstacle geometry must not be null");
    new_drone.Validate();
    new_options.Validate();
    QT_DEMAND(initial.p_W.allFinite() && initial.v_W.allFinite() &&
                  initial.q_WB.coeffs().allFinite() && initial.omega_B.allFinite() &&
                  initial.q_WB.norm() > 0.5,
              "initial drone state must be finite with a unit quaternion");
    for (double w : initial.rotor_speeds) {
      QT_DEMAND(std::isfinite(w) && w >= 0.0, "initial rotor speeds must be finite and >= 0");
    }

    if (!world || built_pool_size != new_options.collision_pool_size) {
      TearDown();
      BuildCore(new_options.collision_pool_size);
    }
    if (body) world->removeRigidBody(body.get());
    body.reset();
    drone_shape.reset();
    for (auto& object : obstacle_objects) world->removeCollisionObject(object.get());

    geometry = std::move(new_geometry);
    drone = new_drone;
    options = new_options;
    options.ring_max_error = geometry->ring_max_error();
    options.obstacle_margin = geometry->obstacle_margin();
    if (built_geometry != geometry.get()) BuildObstacleObjects();
    // Canonical broadphase and solver state: identical to a freshly built world.
    broadphase->resetPool(dispatcher.get());
    solver->reset();
    world->setGravity(btVector3(0, 0, static_cast<btScalar>(-options.gravity)));
    for (auto& object : obstacle_objects) {
      world->addCollisionObject(object.get(), btBroadphaseProxy::StaticFilter,
                                btBroadphaseProxy::AllFilter ^ btBroadphaseProxy::StaticFilter);
    }
    BuildDrone(initial);
    world->addRigidBody(body.get());

    dt = 1.0 / options.physics_rate_hz;
    control_every = std::llround(options.physics_rate_hz / options.controller_rate_hz);
    controller = std::make_unique<GeometricController>(drone);
    plant_mixer = std::make_unique<Mixer>(drone);
    motors = std::make_unique<MotorModel>(drone, dt, options.motor_lag);
    RestartSimulation(initial, options.seed);
  }

  void RestartSimulation(const DroneState& initial, std::uint64_t seed) {
    steps = 0;
    requested_time = 0.0;
    rotor_speeds = initial.rotor_speeds;
    rotor_command = initial.rotor_speeds;
    user_command = initial.rotor_speeds;
    mode = ControlMode::kTracking;
    reference = TrackingReference::Hold(initial.p_W, initial.Yaw());
    reference_fn = nullptr;
    last_control = ControlOutput{};
    last_control.rotor_speeds = initial.rotor_speeds;
    monitor = CollisionMonitor(options.contact_release_time);
    force_rng.seed(DeriveSeed(seed, {1}));
    measure_rng.seed(DeriveSeed(seed, {2}));
    gust_rng.seed(DeriveSeed(seed, {3}));
    gust_decay = std::exp(-dt / options.gust_time_constant);
    gust_innovation = options.gust_stddev * std::sqrt(1.0 - gust_decay * gust_decay);
    gust_W = options.gust_stddev > 0.0 ? Eigen::Vector3d(options.gust_stddev * NormalVector(gust_rng))
                                       : Eigen::Vector3d::Zero();
    measured = TrueState();
    contacts.clear();
  }

  void ResetState(const DroneState& initial, std::uint64_t seed) {
    WorldOptions o = options;
    o.seed = seed;
    const DroneDescription d = drone;  // a copy: Reset assigns to the member
    Reset(geometry, d, o, initial);
  }

  DroneState TrueState() const {
    DroneState s;
    const btTransform& pose = body->getWorldTransform();
    s.p_W = ToEigen(pose.getOrigin());
    const btQuaternion q = pose.getRotation();
    s.q_WB = Eigen::Quaterniond(static_cast<double>(q.w()), static_cast<double>(q.x()),
                                static_cast<double>(q.y()), static_cast<double>(q.z()));
    s.v_W = ToEigen(body->getLinearVelocity());
    s.omega_B = s.q_WB.conjugate() * ToEigen(body->getAngularVelocity());
    s.rotor_speeds = rotor_speeds;
    return s;
  }

  DroneState Measure() {
    DroneState s = TrueState();
    const MeasurementNoise& n = options.measurement_noise;
    if (n.position > 0.0) s.p_W += n.position * NormalVector(measure_rng);
    if (n.velocity > 0.0) s.v_W += n.velocity * NormalVector(measure_rng);
    if (n.attitude > 0.0) {
      const Eigen::Vector3d rot = n.attitude * NormalVector(measure_rng);
      const double angle = rot.norm();
      if (angle > 0.0) s.q_WB = s.q_WB * Eigen::Quaterniond(Eigen::AngleAxisd(angle, rot / angle));
    }
    if (n.angular_velocity > 0.0) s.omega_B += n.angular_velocity * NormalVector(measure_rng);
    return s;
  }

  void Step() {
    if (steps % control_every == 0) {
      measured = Measure();
      if (mode == ControlMode::kTracking) {
        if (reference_fn) reference = reference_fn(static_cast<double>(steps) * dt);
        last_control = controller->Compute(measured, reference);
        rotor_command = last_control.rotor_speeds;
      }
    }
    if (mode == ControlMode::kRotorSpeeds) rotor_command = user_command;
    if (mode == ControlMode::kMotorsOff) rotor_command.fill(0.0);
    motors->Step(rotor_command, rotor_speeds);
    const BodyWrench wrench = plant_mixer->Wrench(rotor_speeds);

    const btMatrix3x3& basis = body->getWorldTransform().getBasis();
    Eigen::Matrix3d R;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) R(r, c) = static_cast<double>(basis[r][c]);
    const Eigen::Vector3d v_air_W = ToEigen(body->getLinearVelocity()) - options.wind_W - gust_W;
    const Eigen::Vector3d drag_B = -drone.linear_drag.cwiseProduct(R.transpose() * v_air_W);
    Eigen::Vector3d force_W = R * (Eigen::Vector3d(0.0, 0.0, wrench.thrust) + drag_B);
    // Gyroscopic torque -ω × Jω, evaluated at the midpoint estimate of the body rate
    // (ω + dt/2 · J⁻¹(τ_rotors − ω × Jω)), so that Bullet's Euler update of ω, which holds the
    // applied torque constant over the step, advances Euler's equations to second order.
    const Eigen::Vector3d omega_B = R.transpose() * ToEigen(body->getAngularVelocity());
    auto gyroscopic = [this](const Eigen::Vector3d& w) -> Eigen::Vector3d {
      return -w.cross(body_inertia.cwiseProduct(w));
    };
    const Eigen::Vector3d omega_mid =
        omega_B + (0.5 * dt) * (wrench.moment_B + gyroscopic(omega_B)).cwiseQuotient(body_inertia);
    const Eigen::Vector3d gyro_B = gyroscopic(omega_mid);
    Eigen::Vector3d torque_W = R * (wrench.moment_B + gyro_B);
    if (options.force_noise > 0.0) force_W += options.force_noise * NormalVector(force_rng);
    if (options.torque_noise > 0.0) torque_W += options.torque_noise * NormalVector(force_rng);
    body->applyCentralForce(ToBt(force_W));
    body->applyTorque(ToBt(torque_W));

    const double speed = static_cast<double>(body->getLinearVelocity().length());
    world->stepSimulation(static_cast<btScalar>(dt), 0, static_cast<btScalar>(dt));
    ++steps;
    if (options.gust_stddev > 0.0) {
      gust_W = gust_decay * gust_W + gust_innovation * NormalVector(gust_rng);
    }
    RecordContacts(speed);
  }

  void RecordContacts(double speed_before_step) {
    contacts.clear();
    const int n = dispatcher->getNumManifolds();
    for (int i = 0; i < n; ++i) {
      const btPersistentManifold* m = dispatcher->getManifoldByIndexInternal(i);
      const btCollisionObject* other = nullptr;
      if (m->getBody0() == body.get()) {
        other = m->getBody1();
      } else if (m->getBody1() == body.get()) {
        other = m->getBody0();
      } else {
        continue;
      }
      // Touching: the surfaces overlap, or the contact solver had to push them apart (Bullet
      // resolves contacts speculatively, so a stopped drone may rest a hair off the surface).
      for (int k = 0; k < m->getNumContacts(); ++k) {
        const btManifoldPoint& point = m->getContactPoint(k);
        if (point.getDistance() <= btScalar(0) || point.getAppliedImpulse() > btScalar(0)) {
          contacts.push_back({static_cast<ObstacleKind>(other->getUserIndex2()), other->getUserIndex()});
          break;
        }
      }
    }
    monitor.Update(static_cast<double>(steps) * dt, contacts, speed_before_step);
  }
};

World::World(const ObstacleSet& obstacles, const DroneDescription& drone,
             const WorldOptions& options, const DroneState& initial)
    : impl_(std::make_unique<Impl>()) {
  options.Validate();
  impl_->Reset(ObstacleGeometry::Make(obstacles, options), drone, options, initial);
}

World::World(std::shared_ptr<const ObstacleGeometry> geometry, const DroneDescription& drone,
             const WorldOptions& options, const DroneState& initial)
    : impl_(std::make_unique<Impl>()) {
  impl_->Reset(std::move(geometry), drone, options, initial);
}

World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

void World::Reset(const ObstacleSet& obstacles, const DroneDescription& drone,
                  const WorldOptions& options, const DroneState& initial) {
  options.Validate();
  const ObstacleGeometry* current = impl_->geometry.get();
  if (current != nullptr && current->obstacles() == obstacles &&
      current->ring_max_error() == options.ring_max_error &&
      current->obstacle_margin() == options.obstacle_margin) {
    impl_->Reset(impl_->geometry, drone, options, initial);  // keep the shapes and objects
  } else {
    impl_->Reset(ObstacleGeometry::Make(obstacles, options), drone, options, initial);
  }
}

void World::Reset(std::shared_ptr<const ObstacleGeometry> geometry, const DroneDescription& drone,
                  const WorldOptions& options, const DroneState& initial) {
  impl_->Reset(std::move(geometry), drone, options, initial);
}

void World::Reset(const DroneState& initial, std::optional<std::uint64_t> seed) {
  impl_->ResetState(initial, seed.value_or(impl_->options.seed));
}

void World::SetReference(const TrackingReference& reference) {
  impl_->reference = reference;
  impl_->reference_fn = nullptr;
  impl_->mode = ControlMode::kTracking;
}

void World::SetReference(std::function<TrackingReference(double)> reference) {
  QT_DEMAND(static_cast<bool>(reference), "reference function must not be empty");
  impl_->reference_fn = std::move(reference);
  impl_->mode = ControlMode::kTracking;
}

void World::CommandRotorSpeeds(const RotorSpeeds& speeds) {
  for (std::size_t i = 0; i < 4; ++i) {
    QT_DEMAND(std::isfinite(speeds[i]), "rotor speed command must be finite");
    impl_->user_command[i] =
        std::clamp(speeds[i], impl_->drone.min_rotor_speed, impl_->drone.max_rotor_speed);
  }
  impl_->mode = ControlMode::kRotorSpeeds;
}

void World::StopMotors() { impl_->mode = ControlMode::kMotorsOff; }

void World::Advance(double seconds) {
  QT_DEMAND(seconds >= 0.0 && std::isfinite(seconds), "Advance needs a finite time >= 0");
  // Accumulate the requested time so that rounding to whole steps never drifts.
  impl_->requested_time += seconds;
  const std::int64_t target = std::llround(impl_->requested_time * impl_->options.physics_rate_hz);
  while (impl_->steps < target) impl_->Step();
}

void World::Step() {
  impl_->requested_time += impl_->dt;
  impl_->Step();
}

DroneState World::State() const { return impl_->TrueState(); }
const DroneState& World::MeasuredState() const { return impl_->measured; }
double World::time() const { return static_cast<double>(impl_->steps) * impl_->dt; }
std::int64_t World::step_count() const { return impl_->steps; }
Eigen::Vector3d World::Wind_W() const { return impl_->options.wind_W + impl_->gust_W; }
const ControlOutput& World::LastControl() const { return impl_->last_control; }
ControlMode World::control_mode() const { return impl_->mode; }

bool World::HasDiverged() const {
  const DroneState s = State();
  return !(s.p_W.allFinite() && s.v_W.allFinite() && s.q_WB.coeffs().allFinite() &&
           s.omega_B.allFinite()) ||
         s.p_W.cwiseAbs().maxCoeff() > 1e4;
}

const CollisionMonitor& World::collisions() const { return impl_->monitor; }
const ObstacleSet& World::obstacles() const { return impl_->geometry->obstacles(); }
const std::shared_ptr<const ObstacleGeometry>& World::geometry() const { return impl_->geometry; }
const DroneDescription& World::drone() const { return impl_->drone; }
const WorldOptions& World::options() const { return impl_->options; }
const RayCaster& World::ray_caster() const { return impl_->geometry->ray_caster(); }

std::optional<double> World::BulletRayDistance(const Eigen::Vector3d& from_W,
                                               const Eigen::Vector3d& to_W) const {
  const btVector3 from = ToBt(from_W);
  const btVector3 to = ToBt(to_W);
  btCollisionWorld::ClosestRayResultCallback callback(from, to);
  callback.m_collisionFilterMask = btBroadphaseProxy::StaticFilter;
  // GJK-based convex casts are exact for rays; the default sub-simplex cast is not.
  callback.m_flags |= btTriangleRaycastCallback::kF_UseGjkConvexCastRaytest;
  impl_->world->rayTest(from, to, callback);
  if (!callback.hasHit()) return std::nullopt;
  return static_cast<double>(callback.m_closestHitFraction) * (to_W - from_W).norm();
}

btDiscreteDynamicsWorld& World::bullet_world() { return *impl_->world; }
btRigidBody& World::bullet_body() { return *impl_->body; }

}  // namespace quadtune::physics
