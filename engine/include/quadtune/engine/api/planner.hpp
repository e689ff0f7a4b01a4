#pragma once
/// \file
/// The planner plug-in: what the engine needs from an online planner, behind a type-erased value
/// (pagmo2 style, `Planner planner{MyPlanner{...}}`).
///
/// A user-defined planner is a plain copyable struct with these const members:
///
///     std::string Name() const;
///     std::vector<ParameterInfo> ShortTermParameters() const;  // θ_s names + defaults
///     std::vector<ParameterInfo> LongTermParameters() const;   // θ_l names + defaults
///     Opaque PrepareMap(std::uint64_t map_seed) const;         // one environment (a map)
///     FlightRecord Fly(const FlightRequest& request, WorkerSlot& slot) const;  // long-term
///     ResolveRecord Resolve(const Opaque& query, const ParamValues& theta_s) const;  // short-term
///
/// Fly() runs one closed-loop mission in the map of `request.map`, reports every planning problem
/// it met through `request.on_query` (an Opaque the same planner can later Resolve()), and asks
/// `request.short_params_provider` for the current θ_s at every plan. `slot` is a world-pool
/// slot: mutable per-task state (e.g. a Bullet world, slot.State<T>()) that the engine hands to
/// one task at a time and reuses across flights. When `request.log_directory` is set, Fly() also
/// keeps the flight's full log for people (`quadtune fly`, `fly --from`): it writes its own log
/// files there and returns its summary facts in FlightRecord::log (see FlightRequest).
///
/// Thread safety: every member of a plug-in must be callable concurrently from many threads
/// (distinct slots); the engine never calls a plug-in's members on the same slot concurrently.

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <type_traits>
#include <typeindex>
#include <typeinfo>
#include <utility>
#include <variant>
#include <vector>

#include "quadtune/common/enum_names.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::engine {

/// Parameter values by name (original units).
using ParamValues = std::map<std::string, double>;

/// One tunable parameter of a planner: its default and the values the planner can fly (the
/// schema an experiment's `parameters:` bounds are checked against when the file loads).
struct ParameterInfo {
  std::string name;
  double default_value = 0.0;
  Range range = Range::Any();  ///< allowed values; a tuning box must lie inside it
  bool integer = false;        ///< true: the planner rounds the value (the box must be integer)
};

/// An immutable, shareable, type-erased value owned by a planner (a map, a recorded query).
/// Copying shares the payload. Thread safety: const access from any thread.
class Opaque {
 public:
  Opaque() = default;
  /// Wraps a value of type T.
  template <class T>
  static Opaque Make(T value) {
    Opaque o;
    o.data_ = std::make_shared<const T>(std::move(value));
    o.type_ = &typeid(T);
    return o;
  }
  /// The payload as T; throws InvariantError when it holds another type or nothing.
  template <class T>
  [[nodiscard]] const T& As() const {
    QT_DEMAND(data_ && *type_ == typeid(T), "Opaque: wrong payload type");
    return *static_cast<const T*>(data_.get());
  }
  [[nodiscard]] bool Empty() const { return data_ == nullptr; }

 private:
  std::shared_ptr<const void> data_;
  const std::type_info* type_ = nullptr;
};

/// Per-task mutable state of the world pool (e.g. a Bullet world). Owned by one task at a time.
class WorkerSlot {
 public:
  int index = 0;  ///< slot number in the pool
  int uses = 0;   ///< flights flown in this slot

  /// The slot's state of type T (what a planner keeps between flights, e.g. a struct holding
  /// its physics::World), value-initialised on first use and kept until ResetState(). Each type
  /// has its own state, so plug-ins sharing a pool never see each other's.
  template <class T>
  [[nodiscard]] T& State() {
    std::shared_ptr<void>& held = states_[std::type_index(typeid(T))];
    if (held == nullptr) held = std::make_shared<T>();
    return *static_cast<T*>(held.get());
  }
  /// Drops every state (the next flight rebuilds what it needs), e.g. after an exception.
  void ResetState() { states_.clear(); }

 private:
  std::map<std::type_index, std::shared_ptr<void>> states_;
};

/// What a flight is asked to do.
struct FlightRequest {
  Opaque map;               ///< from PrepareMap
  ParamValues params;       ///< θ_l and θ_s (missing names keep the planner's defaults)
  std::uint64_t seed = 0;   ///< seed of the flight's random streams
  /// Called at every plan with the flight time (s) and θ_s in force; may change θ_s (the engine
  /// injects the current best θ_s here). May be empty.
  std::function<void(double time, ParamValues& theta_s)> short_params_provider;
  /// Receives every planning problem met, as an Opaque for Resolve(). May be empty.
  std::function<void(const Opaque& query)> on_query;
  /// Polled by the flight; true stops it. May be empty.
  std::function<bool()> cancelled;
  /// Empty (the tuner's flights): no log. Otherwise an existing folder: the flight keeps its full
  /// log for people there (the planner's own files, e.g. flight.csv, never summary.json, which
  /// the caller writes), returns its summary facts in FlightRecord::log and sets
  /// FlightRecord::logged. A cancelled flight writes nothing. A planner that keeps no log
  /// ignores it. The flight itself must not depend on it.
  std::string log_directory;
};

/// One fact of a flight's log summary: an integer, a number, a text or a list of numbers.
using LogFact = std::variant<std::int64_t, double, std::string, std::vector<double>>;
/// A flight's summary facts by name (keys of `quadtune fly`'s summary.json).
using LogFacts = std::map<std::string, LogFact>;

/// Outcome status of one evaluation (flight, re-solve or objective).
enum class EvalStatus { kOk, kFailed, kCancelled };
constexpr auto EnumNames(EvalStatus) {
  return std::array{EnumName{EvalStatus::kOk, "ok"}, EnumName{EvalStatus::kFailed, "failed"},
                    EnumName{EvalStatus::kCancelled, "cancelled"}};
}

/// What became of one evaluation, stored with it (column `state`) beside the EvalStatus: kOk
/// only for a flight that reached every waypoint without a collision and a re-solve that found
/// a trajectory; otherwise what went wrong. StateOf (objectives.hpp) decides it, in one place.
enum class EvalState {
  kOk,
  kCollision,      ///< the flight finished, with collisions (n_c > 0)
  kIncomplete,     ///< the flight did not finish and its planner gave no reason
  kTimeout,        ///< the flight did not finish within its time limit
  kStalled,        ///< the flight stopped making progress
  kDiverged,       ///< the simulation diverged
  kSolverFailure,  ///< no trajectory: every plan of an unfinished flight, or a re-solve, failed
  kError,          ///< an exception or error inside the evaluation
  kCancelled,      ///< stopped by a cancel request
};
constexpr auto EnumNames(EvalState) {
  return std::array{EnumName{EvalState::kOk, "ok"},
                    EnumName{EvalState::kCollision, "collision"},
                    EnumName{EvalState::kIncomplete, "incomplete"},
                    EnumName{EvalState::kTimeout, "timeout"},
                    EnumName{EvalState::kStalled, "stalled"},
                    EnumName{EvalState::kDiverged, "diverged"},
                    EnumName{EvalState::kSolverFailure, "solver_failure"},
                    EnumName{EvalState::kError, "error"},
                    EnumName{EvalState::kCancelled, "cancelled"}};
}

/// What a flight produced (SI units) — the long-term objective's inputs.
struct FlightRecord {
  EvalStatus status = EvalStatus::kOk;
  std::string message;           ///< why it failed / how it ended
  bool completed = false;        ///< every waypoint reached
  /// Why the flight ended before its last waypoint (kTimeout, kStalled, kDiverged, kError,
  /// kCancelled); kOk when it did not, or when the planner does not say (StateOf).
  EvalState ending = EvalState::kOk;
  double flight_time = 0.0;      ///< t_f (s)
  int collisions = 0;            ///< n_c
  int emergency_stops = 0;       ///< n_e
  int plans = 0;
  int failed_plans = 0;
  int failed_attempts = 0;       ///< Σ n_s
  int fallback_plans = 0;        ///< steps that flew the stop-and-go fallback
  double compute_units = 0.0;    ///< Σ deterministic compute units
  double jerk_integral = 0.0;    ///< ∫|jerk|² dt (m²/s⁵)
  double min_clearance = 0.0;    ///< (m)
  double wall_time = 0.0;        ///< wall-clock duration (s); not deterministic
  int queries = 0;               ///< planning queries reported through on_query
  /// With FlightRequest::log_directory: true when the planner wrote its log there, and the
  /// flight's and its map's facts beyond the fields above, by the planner's names (e.g. the
  /// closed loop's status, max_tracking_error, start, goal, obstacles). Empty otherwise.
  bool logged = false;
  LogFacts log;
};

/// What one re-solve of a recorded query produced — the short-term objective's inputs.
struct ResolveRecord {
  EvalStatus status = EvalStatus::kOk;  ///< kFailed only for errors, not for failed plans
  std::string message;
  bool success = false;          ///< a trajectory was found
  int attempts = 0;
  int failed_attempts = 0;       ///< n_s
  double solve_time_s = 0.0;     ///< wall-clock t_c (s)
  double compute_units = 0.0;    ///< deterministic cost (1 unit ≙ 0.1 ms nominal)
  double duration = 0.0;         ///< t_exe of the trajectory (s)
  double jerk_integral = 0.0;    ///< ∫|jerk|² dt of the trajectory (m²/s⁵)
  double min_clearance = 0.0;    ///< (m)
};

/// The type-erased planner. A value: copies are independent (the payloads share immutable data).
class Planner {
 public:
  /// Wraps a user-defined planner (see the file comment).
  template <class T>
    requires(!std::is_same_v<std::decay_t<T>, Planner>)
  Planner(T udp) : impl_(std::make_unique<Model<T>>(std::move(udp))) {}  // NOLINT implicit
  Planner(const Planner& other) : impl_(other.impl_->Clone()) {}
  Planner& operator=(const Planner& other) {
    if (this != &other) impl_ = other.impl_->Clone();
    return *this;
  }
  Planner(Planner&&) noexcept = default;
  Planner& operator=(Planner&&) noexcept = default;
  ~Planner() = default;

  [[nodiscard]] std::string Name() const { return impl_->Name(); }
  [[nodiscard]] std::vector<ParameterInfo> ShortTermParameters() const {
    return impl_->ShortTermParameters();
  }
  [[nodiscard]] std::vector<ParameterInfo> LongTermParameters() const {
    return impl_->LongTermParameters();
  }
  /// All defaults, θ_s then θ_l.
  [[nodiscard]] ParamValues Defaults() const;
  [[nodiscard]] Opaque PrepareMap(std::uint64_t map_seed) const { return impl_->PrepareMap(map_seed); }
  [[nodiscard]] FlightRecord Fly(const FlightRequest& request, WorkerSlot& slot) const {
    return impl_->Fly(request, slot);
  }
  [[nodiscard]] ResolveRecord Resolve(const Opaque& query, const ParamValues& theta_s) const {
    return impl_->Resolve(query, theta_s);
  }
  /// The wrapped plug-in, or nullptr when it is not a T.
  template <class T>
  [[nodiscard]] const T* Extract() const {
    auto* m = dynamic_cast<const Model<T>*>(impl_.get());
    return m ? &m->udp : nullptr;
  }

 private:
  struct Concept {
    virtual ~Concept() = default;
    [[nodiscard]] virtual std::unique_ptr<Concept> Clone() const = 0;
    [[nodiscard]] virtual std::string Name() const = 0;
    [[nodiscard]] virtual std::vector<ParameterInfo> ShortTermParameters() const = 0;
    [[nodiscard]] virtual std::vector<ParameterInfo> LongTermParameters() const = 0;
    [[nodiscard]] virtual Opaque PrepareMap(std::uint64_t) const = 0;
    [[nodiscard]] virtual FlightRecord Fly(const FlightRequest&, WorkerSlot&) const = 0;
    [[nodiscard]] virtual ResolveRecord Resolve(const Opaque&, const ParamValues&) const = 0;
  };
  template <class T>
  struct Model final : Concept {
    explicit Model(T u) : udp(std::move(u)) {}
    std::unique_ptr<Concept> Clone() const override { return std::make_unique<Model>(udp); }
    std::string Name() const override { return udp.Name(); }
    std::vector<ParameterInfo> ShortTermParameters() const override {
      return udp.ShortTermParameters();
    }
    std::vector<ParameterInfo> LongTermParameters() const override {
      return udp.LongTermParameters();
    }
    Opaque PrepareMap(std::uint64_t s) const override { return udp.PrepareMap(s); }
    FlightRecord Fly(const FlightRequest& r, WorkerSlot& w) const override { return udp.Fly(r, w); }
    ResolveRecord Resolve(const Opaque& q, const ParamValues& p) const override {
      return udp.Resolve(q, p);
    }
    T udp;
  };
  std::unique_ptr<Concept> impl_;
};

/// The plug-in of a Planner that holds none yet (a default-constructed engine::Experiment before
/// its `planner:` map is read): no parameters and an empty map; Fly() and Resolve() report
/// EvalStatus::kFailed with the message "no planner". Thread safety: stateless.
struct NoPlanner {
  std::string Name() const { return "none"; }
  std::vector<ParameterInfo> ShortTermParameters() const { return {}; }
  std::vector<ParameterInfo> LongTermParameters() const { return {}; }
  Opaque PrepareMap(std::uint64_t /*map_seed*/) const { return {}; }
  FlightRecord Fly(const FlightRequest& /*request*/, WorkerSlot& /*slot*/) const {
    FlightRecord r;
    r.status = EvalStatus::kFailed;
    r.message = "no planner";
    return r;
  }
  ResolveRecord Resolve(const Opaque& /*query*/, const ParamValues& /*theta_s*/) const {
    ResolveRecord r;
    r.status = EvalStatus::kFailed;
    r.message = "no planner";
    return r;
  }
};

}  // namespace quadtune::engine
