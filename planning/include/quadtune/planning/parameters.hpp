#pragma once
/// \file
/// The planner's parameters: the short-term set θ_s, scored right after a plan; the long-term set
/// θ_l, scored after a flight; and fixed safety parameters that are not tuned (paper Sec. IV-A).
/// Defaults follow EGO-Planner where the two planners share a quantity (docs/design.md,
/// "Reference values", names each source and each default of quadtune's own).
///
/// Thread safety: a value type.

#include <string>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"

namespace quadtune::planning {

struct PlannerParams {
  // ---- short-term θ_s (tuned by PSO on re-solved planning queries) ----
  double w_col = 0.5;  ///< collision-penalty weight (relative to jerk energy), > 0
  double w_dyn = 0.1;  ///< dynamic-feasibility penalty weight, > 0
  int n_pol = 5;       ///< number of polynomial pieces of a local trajectory, [2, 12]

  // ---- long-term θ_l (tuned by BayesOpt on flights) ----
  double v_des = 2.0;  ///< desired (maximum) velocity (m/s), (0, 15]
  double h_pl = 7.5;   ///< local planning horizon: distance to the local goal (m), [1, 30]
  double t_pl = 1.0;   ///< re-plan interval (s), [0.05, 10]

  // ---- fixed (clear safety meaning; not tuned) ----
  double a_max = 3.0;            ///< acceleration limit (m/s^2), > 0
  /// Desired clearance to obstacles in the collision cost (m), > 0 (a soft preference; the hard
  /// limit is `inflation`).
  double clearance = 0.5;
  /// Obstacle inflation (m), >= 0: the drone's safety radius. The occupancy map (front end,
  /// collision checks) is inflated by it, and an accepted plan keeps at least this distance from
  /// every obstacle. The default is the ~1 kg drone's collision radius (0.2 m).
  double inflation = 0.2;
  double tau_c = 1.0;            ///< emergency stop if a collision is predicted within (s), > 0
  double goal_tolerance = 0.3;   ///< mission waypoint reached within (m), > 0
  double no_replan_near_goal = 2.0;  ///< no periodic re-plan within this distance of the goal (m)
  double map_resolution = 0.1;   ///< occupancy / distance-field voxel size (m), (0, 1]
  double w_smooth = 1.0;         ///< jerk-energy weight, > 0
  /// Weight of slowing a plan down below its nominal time allocation at v_des (J_time =
  /// ΣT̄ (ln τ)², MinJerkProblem), (1/s), >= 0. Large: plans fly at about v_des where they can.
  double w_time = 20.0;
  int max_attempts = 3;          ///< planning attempts per re-plan before it counts as failed, >= 1

  /// Names of the tunable parameters, θ_s then θ_l (PlannerParameterSchema()'s roles).
  static const std::vector<std::string>& TunableNames();
  static const std::vector<std::string>& ShortTermNames();  ///< {w_col, w_dyn, n_pol}
  static const std::vector<std::string>& LongTermNames();   ///< {v_des, h_pl, t_pl}

  /// Reads a parameter by name (any field above); unknown names throw ConfigError.
  [[nodiscard]] double Get(const std::string& name) const;
  /// Sets a parameter by name (integers are rounded); unknown names throw ConfigError.
  /// Does not validate: call Validate() after a batch of Sets.
  void Set(const std::string& name, double value);

  /// Throws ConfigError(origin, key, allowed range) for the first out-of-range field. Called
  /// where parameters enter (files, the command line, Set batches, the Replanner and a flight);
  /// the back ends take validated parameters.
  void Validate(const std::string& origin = "") const;

  /// Reads the keys of PlannerParamsFields() present in `map` over the defaults; unknown keys
  /// and bad values throw ConfigError naming the file and key.
  static PlannerParams FromYaml(const YamlMap& map);

  friend bool operator==(const PlannerParams&, const PlannerParams&) = default;
};

/// The keys of a planner parameter map (`planner.fixed`, ...): reading, writing and the
/// configuration reference; built from the table behind PlannerParameterSchema()
/// (parameter_schema.hpp).
const Fields<PlannerParams>& PlannerParamsFields();

}  // namespace quadtune::planning
