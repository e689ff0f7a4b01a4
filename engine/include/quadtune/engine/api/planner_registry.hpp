#pragma once
/// \file
/// The planner registry: which `planner.type` names an experiment file may give, how each builds
/// its plug-in (engine::Planner) from the file's `planner:` map, and which values each tunable
/// parameter may take.
///
/// Built in: `ipopt` (IpoptPlanner) and `ego` (EgoPlanner), present before any other
/// registration. A program adds its own planner without editing quadtune's sources, before it
/// loads an experiment:
///
///     engine::RegisterPlanner("mine", [](const YamlMap& planner, const std::string& base_dir) {
///       return engine::Planner{MyPlanner{...}};
///     }, engine::PlannerSchema::Of(MyPlanner{}));
///
/// or with a namespace-scope engine::PlannerRegistration object in one of the program's own
/// source files (not in a static library: the linker drops objects nothing refers to).
///
/// Room engine/api: its files include engine headers of this room only (scripts/check_rooms.py;
/// docs/design.md, "Architecture").
///
/// Thread safety: every function may be called from any thread (a mutex guards the table);
/// register before loading experiments that name the planner.

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/api/planner.hpp"
#include "quadtune/engine/api/planner_schema.hpp"
#include "quadtune/planning/trajectory_backend.hpp"

namespace quadtune::engine {

/// Builds a plug-in from an experiment's `planner:` map (the YamlMap names the file and key path
/// for errors). `base_dir` is the experiment file's folder (for ResolvePath). A factory reads
/// its keys with the YamlMap accessors, rejects unknown ones (the map also holds `type`) and
/// throws ConfigError for bad input.
using PlannerFactory =
    std::function<Planner(const YamlMap& planner, const std::string& base_dir)>;

/// For a planner type flown in quadtune's closed loop (sim::Fly, e.g. a BackendPlanner): builds
/// its trajectory back end with default settings, the one `quadtune fly --planner NAME` flies.
using BackendFactory = std::function<std::shared_ptr<const planning::TrajectoryBackend>()>;

/// One registered planner type.
struct PlannerType {
  std::string name;  ///< the `planner.type` value
  PlannerFactory factory;
  PlannerSchema schema;
  BackendFactory backend;  ///< empty for planners with a loop of their own (toy, sleep)
};

/// Adds a planner type. `name` must be non-empty, of lower-case letters, digits and '_', and not
/// yet registered; `factory` must not be empty; `schema` must name each parameter once. Throws
/// std::invalid_argument otherwise. `backend` may be empty.
void RegisterPlanner(const std::string& name, PlannerFactory factory, PlannerSchema schema,
                     BackendFactory backend = {});

/// Registers a planner type when constructed (a namespace-scope object in a program's source).
struct PlannerRegistration {
  PlannerRegistration(const std::string& name, PlannerFactory factory, PlannerSchema schema,
                      BackendFactory backend = {}) {
    RegisterPlanner(name, std::move(factory), std::move(schema), std::move(backend));
  }
};

/// The registered names, sorted.
[[nodiscard]] std::vector<std::string> RegisteredPlanners();

/// The planner type called `name`, or nullopt.
[[nodiscard]] std::optional<PlannerType> FindPlanner(const std::string& name);

/// The registered names of the planner types flown in quadtune's closed loop (those with a
/// BackendFactory), sorted.
[[nodiscard]] std::vector<std::string> ClosedLoopPlanners();

/// The trajectory back end of the closed-loop planner type `name`, built by its BackendFactory.
/// Throws ConfigError(file, key, "'NAME' is not a registered planner flown in the closed loop;
/// registered: ...", listing ClosedLoopPlanners()) when `name` is not registered or has no back
/// end (`quadtune fly --planner`, an adaptation experiment's `planner.type`).
[[nodiscard]] std::shared_ptr<const planning::TrajectoryBackend> BuildClosedLoopBackend(
    const std::string& name, const std::string& file, const std::string& key);

/// A plug-in built from a `planner:` map.
struct BuiltPlanner {
  std::string type;  ///< the `planner.type` it was built as
  Planner planner;
  PlannerSchema schema;  ///< the type's registered schema
};

/// Reads `planner.type` (default `ipopt`) and builds it with its factory. An unknown type throws
/// ConfigError(file, "planner.type", ...) listing the registered names. Throws InvariantError
/// when the built plug-in's parameters differ from the registered schema (a registration bug).
[[nodiscard]] BuiltPlanner BuildPlanner(const YamlMap& planner, const std::string& base_dir);

}  // namespace quadtune::engine
