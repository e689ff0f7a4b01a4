// _core.register_planner: a waypoint planner written in Python, flown in quadtune's closed loop
// (engine::BackendPlanner: Bullet world, sensing, local map, replanning FSM) as a registered
// `planner.type`, tuned like any other.
//
// The Python object's waypoints(query, params) returns the points to pass between the query's
// start and its local goal; PythonBackend joins start, points and goal by quintic pieces
// (planning::QuinticBoundaryValue) flown at v_des, checks the curve against the query's
// occupancy snapshot and the limits, and retries at retry_slowdown times the speed, as a back end
// does (planning/trajectory_backend.hpp).
//
// Threads: Solve() runs on the engine's worker threads; it takes the GIL for the Python call
// only, so Python planners run one call at a time while the physics and the checks run in
// parallel without it. A Python exception fails its evaluation and cancels the run
// (ReportPlannerFailure): nothing of the round is stored, and _core.run raises it.
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/engine/api/planner_registry.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/planning/local_map.hpp"
#include "quadtune/planning/quintic.hpp"
#include "quadtune/planning/trajectory_backend.hpp"

namespace quadtune::python {

namespace py = pybind11;
namespace qp = planning;
using Eigen::Vector3d;

namespace {

/// A registered Python planner. The reference to the object is never given back: registrations
/// live as long as the process, and nothing may touch Python after the interpreter is gone.
struct Slot {
  std::string name;
  PyObject* planner = nullptr;  // owned reference; replaced under the GIL
};

/// What a Python planner sees of a planning query (a copy; the occupancy snapshot is shared).
struct Query {
  double time = 0.0;
  Vector3d start, velocity, acceleration, goal, goal_velocity;
  bool goal_is_mission_goal = false;
  std::vector<Vector3d> path;
  std::shared_ptr<const qp::LocalMap> map;

  [[nodiscard]] bool Occupied(const Vector3d& p) const {
    return map != nullptr && map->IsOccupied(p);
  }
};

/// The planning parameters as a dict: θ_s, θ_l and the fixed limits a planner needs.
py::dict ParamsDict(const qp::PlannerParams& params) {
  py::dict d;
  for (const std::string& name : qp::PlannerParams::TunableNames())
    d[name.c_str()] = params.Get(name);
  d["n_pol"] = params.n_pol;
  for (const char* name : {"a_max", "inflation", "clearance"}) d[name] = params.Get(name);
  return d;
}

/// Calls the planner's waypoints(); "" and the points, or the failure.
std::string CallPlanner(const Slot& slot, const qp::PlanningQuery& q,
                        const qp::PlannerParams& params, std::vector<Vector3d>* points) {
  const py::gil_scoped_acquire gil;
  Query query{
      q.time,           q.p0_W,     q.v0_W, q.a0_W, q.goal_W, q.goal_v_W, q.goal_is_mission_goal,
      q.initial_path_W, q.occupancy};
  py::object result;
  try {
    result = py::handle(slot.planner).attr("waypoints")(query, ParamsDict(params));
  } catch (py::error_already_set& e) {
    return e.what();
  }
  std::vector<std::array<double, 3>> raw;
  try {
    raw = result.cast<std::vector<std::array<double, 3>>>();
  } catch (const py::cast_error&) {
    return "waypoints() must return a sequence of (x, y, z) points, got " +
           std::string(py::repr(result)).substr(0, 200);
  }
  for (const auto& p : raw) {
    points->emplace_back(p[0], p[1], p[2]);
    if (!points->back().allFinite()) return "waypoints() returned a point that is not finite";
  }
  return "";
}

/// Start, the planner's points (those within 1 mm of their predecessor or of the goal dropped)
/// and the goal.
std::vector<Vector3d> Route(const qp::PlanningQuery& q, const std::vector<Vector3d>& inner) {
  std::vector<Vector3d> route{q.p0_W};
  for (const Vector3d& p : inner) {
    if ((p - route.back()).norm() > 1e-3 && (p - q.goal_W).norm() > 1e-3) route.push_back(p);
  }
  route.push_back(q.goal_W);
  return route;
}

/// The quintic pieces through `route` at up to `speed`. A speed per point: `speed`, less where
/// the route turns (s² θ / L <= a_max / 4 for a turn by θ, L the shorter leg), the start's and the
/// goal's from the query, capped so that no piece needs more than a_max / 4 to change speed (a
/// forward and a backward pass); each piece takes the time of a constant acceleration between its
/// end speeds (>= 0.05 s). Inner points get the velocity and acceleration of finite differences
/// over their neighbours (Catmull-Rom), so positions, times and derivatives agree; the goal keeps
/// the direction of the query's goal velocity.
qp::Trajectory Join(const std::vector<Vector3d>& route, const qp::PlanningQuery& q, double speed,
                    double a_max) {
  const std::size_t n = route.size();
  std::vector<double> s(n, 0.0);  // speed at each point
  s.front() = q.v0_W.norm();
  s.back() = q.goal_v_W.norm();
  for (std::size_t k = 1; k + 1 < n; ++k) {
    // Turning by θ over the shorter leg L at speed s takes about s² θ / L: keep it <= a_max / 4.
    const Vector3d in = route[k] - route[k - 1];
    const Vector3d out = route[k + 1] - route[k];
    const double theta = std::acos(std::clamp(in.normalized().dot(out.normalized()), -1.0, 1.0));
    s[k] = std::min(
        speed, std::sqrt(0.25 * a_max * std::min(in.norm(), out.norm()) / std::max(theta, 1e-9)));
  }
  const auto reachable = [&](std::size_t from, std::size_t k) {  // from the speed at `from`
    return std::sqrt(s[from] * s[from] + 0.5 * a_max * (route[k] - route[from]).norm());
  };
  for (std::size_t k = 1; k < n; ++k) s[k] = std::min(s[k], reachable(k - 1, k));
  for (std::size_t k = n - 1; k-- > 1;) s[k] = std::min(s[k], reachable(k + 1, k));
  std::vector<double> T(n - 1);
  std::vector<Vector3d> mean(n - 1);  // mean velocity of each piece
  for (std::size_t k = 0; k + 1 < n; ++k) {
    T[k] = std::max(2.0 * (route[k + 1] - route[k]).norm() / std::max(s[k] + s[k + 1], 1e-3), 0.05);
    mean[k] = (route[k + 1] - route[k]) / T[k];
  }
  std::vector<Vector3d> v(n, Vector3d::Zero());
  std::vector<Vector3d> a(n, Vector3d::Zero());
  v.front() = q.v0_W;
  a.front() = q.a0_W;
  v.back() =
      s.back() > 0.0 ? Vector3d(q.goal_v_W * s.back() / q.goal_v_W.norm()) : Vector3d::Zero();
  for (std::size_t k = 1; k + 1 < n; ++k) {
    v[k] = (route[k + 1] - route[k - 1]) / (T[k - 1] + T[k]);
    a[k] = 2.0 * (mean[k] - mean[k - 1]) / (T[k - 1] + T[k]);
  }
  std::vector<qp::Trajectory::Coefficients> pieces;
  for (std::size_t k = 0; k + 1 < n; ++k) {
    pieces.push_back(
        qp::QuinticBoundaryValue(route[k], v[k], a[k], route[k + 1], v[k + 1], a[k + 1], T[k]));
  }
  return {std::move(T), std::move(pieces)};
}

/// Samples the result's trajectory every 0.02 s: status, limits, clearance; returns the samples.
std::size_t Check(const qp::LocalMap& map, const qp::PlannerParams& params, qp::PlanResult* r) {
  constexpr double kTolerance = 1.05;  // on v_des and a_max
  const std::vector<qp::TrajectorySample> samples = r->trajectory.Sample(0.02);
  // A plan may start inside the inflated region; it must leave it and stay out.
  const auto free = std::find_if(samples.begin(), samples.end(),
                                 [&](const auto& s) { return !map.IsOccupied(s.p_W); });
  const bool collision =
      std::any_of(free, samples.end(), [&](const auto& s) { return map.IsOccupied(s.p_W); });
  for (const qp::TrajectorySample& s : samples) {
    r->max_speed = std::max(r->max_speed, s.v_W.norm());
    r->max_acceleration = std::max(r->max_acceleration, s.a_W.norm());
  }
  r->duration = r->trajectory.Duration();
  r->cost.jerk = r->trajectory.JerkEnergy();
  r->min_clearance = collision ? 0.0 : map.options().inflation;
  r->status =
      collision ? qp::PlanStatus::kCollision
      : r->max_speed > kTolerance * params.v_des || r->max_acceleration > kTolerance * params.a_max
          ? qp::PlanStatus::kDynamicsViolated
          : qp::PlanStatus::kSuccess;
  r->message = collision ? "the curve enters an inflated obstacle"
               : r->Ok() ? ""
                         : "over the velocity or acceleration limit";
  return samples.size();
}

/// The trajectory back end of a Python planner (see the file comment).
class PythonBackend final : public qp::TrajectoryBackend {
 public:
  explicit PythonBackend(std::shared_ptr<const Slot> slot) : slot_(std::move(slot)) {}

  [[nodiscard]] std::string Name() const override { return slot_->name; }
  [[nodiscard]] qp::QuerySnapshot Snapshot() const override {
    return qp::QuerySnapshot::kOccupancy;
  }
  [[nodiscard]] std::optional<qp::PlanResult> Fallback(const qp::PlanningQuery& /*query*/,
                                                       const qp::PlannerParams& /*params*/,
                                                       double /*speed*/) const override {
    return std::nullopt;
  }

  [[nodiscard]] qp::PlanOutcome Solve(const qp::PlanningQuery& query,
                                      const qp::PlannerParams& params,
                                      const qp::LocalPlannerOptions& options) const override {
    const auto started = std::chrono::steady_clock::now();
    qp::PlanOutcome out;
    std::vector<Vector3d> inner;
    const std::string failure = CallPlanner(*slot_, query, params, &inner);
    if (!failure.empty()) {
      // The evaluation fails (the engine catches this at its boundary) and the run is cancelled
      // at once, so the round, cancelled, is not stored; _core.run raises the message.
      const std::string message = "Python planner '" + slot_->name + "': " + failure;
      ReportPlannerFailure(message);
      throw std::runtime_error(message);
    }
    if (query.occupancy == nullptr) {
      out.result.status = qp::PlanStatus::kInvalidInput;
      out.result.message = "the query has no occupancy snapshot";
      return out;
    }
    const std::vector<Vector3d> route = Route(query, inner);
    double speed = params.v_des;
    for (int attempt = 0; attempt < params.max_attempts;
         ++attempt, speed *= options.retry_slowdown) {
      ++out.attempts;
      out.result = qp::PlanResult{};
      out.result.trajectory = Join(route, query, speed, params.a_max);
      // Deterministic work measure: 1 unit per attempt, 1 per Python call and per 100 samples.
      out.result.compute_units =
          2.0 + 0.01 * static_cast<double>(Check(*query.occupancy, params, &out.result));
      out.compute_units += out.result.compute_units;
      if (out.Ok()) break;
      ++out.failed_attempts;
    }
    out.solve_time_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    out.result.solve_time_s = out.solve_time_s;
    return out;
  }

 private:
  std::shared_ptr<const Slot> slot_;
};

/// Registers `name` as a closed-loop planner type flying `planner`, or (already registered by
/// this function) replaces its object.
void RegisterPythonPlanner(const std::string& name, const py::object& planner) {
  if (!py::hasattr(planner, "waypoints") || !PyCallable_Check(planner.attr("waypoints").ptr())) {
    throw ConfigError("", "planner", "a Python planner needs a method waypoints(query, params)");
  }
  static auto* slots = new std::map<std::string, std::shared_ptr<Slot>>;  // guarded by the GIL
  if (const auto it = slots->find(name); it != slots->end()) {
    PyObject* old = it->second->planner;
    it->second->planner = planner.inc_ref().ptr();
    Py_DECREF(old);
    return;
  }
  auto slot = std::make_shared<Slot>(Slot{name, nullptr});
  auto backend = [slot] { return std::make_shared<const PythonBackend>(slot); };
  engine::RegisterPlanner(
      name,
      [slot, backend](const YamlMap& map, const std::string& base_dir) {
        return engine::Planner{engine::BackendPlanner{
            slot->name, engine::ClosedLoopOptions::FromYaml(map, base_dir), backend()}};
      },
      engine::BackendPlanner::Schema(), backend);
  slot->planner = planner.inc_ref().ptr();
  slots->emplace(name, slot);
}

}  // namespace

void BindPlanners(py::module_& m) {
  py::class_<Query>(m, "Query", "A planning query as a Python planner sees it (world frame, m, s).")
      .def_readonly("time", &Query::time, "flight time when the query was made (s)")
      .def_readonly("start", &Query::start, "start position")
      .def_readonly("velocity", &Query::velocity, "start velocity (m/s)")
      .def_readonly("acceleration", &Query::acceleration, "start acceleration (m/s²)")
      .def_readonly("goal", &Query::goal, "local goal")
      .def_readonly("goal_velocity", &Query::goal_velocity, "velocity at the local goal (m/s)")
      .def_readonly("goal_is_mission_goal", &Query::goal_is_mission_goal)
      .def_readonly("path", &Query::path, "front-end (A*) path through the local map, start → goal")
      .def("occupied", &Query::Occupied, py::arg("point"),
           "True when the point lies in the inflated local map (an obstacle seen, or too close)");
  m.def("register_planner", &RegisterPythonPlanner, py::arg("name"), py::arg("planner"),
        "Registers `planner` (an object with waypoints(query, params)) as planner.type `name`.");
}

}  // namespace quadtune::python
