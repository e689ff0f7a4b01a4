#pragma once
/// \file
/// Online adaptation of the desired velocity v_des in changing environments (paper Sec. IV-B),
/// and the experiment that flies it (`quadtune adapt`).
///
/// Mechanism (OnlineAdapter, a sim::PlanAdapter installed in the Replanner):
///  1. Whenever a trajectory starts executing at t0, the point P_s at arc length R (`lookahead`)
///     along it is fixed, with its time t_s and state (p, v, a). A segment starts: a fresh
///     BayesOpt over v_des ∈ [v_min, v_max] (state of earlier segments cleared: the environment
///     has changed), seeded DeriveSeed(seed, {segment}).
///  2. While the drone approaches P_s, `trials_per_segment` trials run at fixed instants of
///     simulated time t0 + k (t_s − t0) / N (k = 0 … N−1; all still due run at t_s), so the
///     count never depends on the wall clock. Each trial asks BO for one v_des, plans from P_s
///     on the latest map (LocalPlanner's front end and the snapshot the back end reads, then the
///     flight's planning::TrajectoryBackend), and scores the plan with the changing-environment
///     short-term objective (engine::ShortTermObjective):
///       f_s = w_t t_exe + w_p ∫|jerk|² dt + w_c J_c,  J_c = (C − c_obs)² if c_obs < C else 0.
///     Before each trial, BayesOpt::AdvanceAge(Δt) ages the earlier trials by the simulated
///     time passed, so their noise grows (`noise_growth` per second): the map kept changing.
///  3. At t_s the trial with the smallest f_s among the successful ones is handed to the
///     Replanner and executed from P_s on, with its v_des kept in force; its start is the next
///     segment's t0. When no trial succeeded, the FSM's own re-planning takes over (with the
///     v_des in force). Periodic re-plans are held while a segment is pending; re-plans for a
///     predicted collision still happen (they end the segment).
///
/// A failed trial (front end or solver failure, a plan outside the limits) is recorded with the
/// objective's failure value and told to BO; it is never thrown. Trials solve with at most two
/// attempts of the back end (Ipopt: warm, then cold start, never the slowed-down retries, so
/// every trial's plan belongs to the v_des it was asked for; EGO: its second attempt allocates
/// 1 / retry_slowdown times the time). A plan from P_s whose start speed exceeds the proposed v_des
/// cannot keep |v| <= v_des at its start: such a trial asks the planner to brake
/// (PlanningQuery::braking_deceleration = braking_fraction · a_max: its time allocation and speed
/// penalty follow a braking at that rate from |v_s| down to v_des), and its plan is accepted when
/// it stays within the acceleration limit, never exceeds |v_s| and is down to v_des by the time
/// that braking would be, τ_b = (|v_s| − v_des) / (braking_fraction · a_max) (each with the
/// limit_tolerance and check_dt of sim::FlightPlannerOptions::optimizer), so the drone can slow
/// down on entering a dense zone. The Ipopt back end plans the braking; the EGO back end ignores
/// braking_deceleration, and its plans are judged by the same envelope.
///
/// In mode `context` nothing is planned from P_s: on the first tick after a trajectory starts,
/// the context policy's v_des for the free range measured at P_s becomes the v_des of every
/// following plan, the FSM's own re-plans included (RunAdaptFlight installs context_v_des() as
/// the flight's parameter provider). Every adaptation flight lets the FSM's re-plans slow down
/// to a lowered v_des inside the same braking envelope (sim::ReplannerOptions::
/// slow_down_fraction = braking_fraction).
///
/// The experiment flies the planner type named by its `planner.type` (default `ipopt`): any
/// registered type with a BackendFactory (planner_registry.hpp), through sim::Scenario,
/// sim::MakeWorld and sim::Fly with that back end; the adapter plans its trials with it too.
///
/// Room engine/adaptation: its files include engine headers of this room, api and experiment only
/// (scripts/check_rooms.py; docs/design.md, "Architecture").
///
/// Thread safety: an OnlineAdapter belongs to one flight (one thread). Options, records and
/// AdaptExperiment are values; RunAdaptFlight only uses its arguments and may run concurrently.

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/common/yaml.hpp"
#include "quadtune/engine/adaptation/context_policy.hpp"
#include "quadtune/engine/experiment/objectives.hpp"
#include "quadtune/layout/layout.hpp"
#include "quadtune/optimizers/bayes_opt.hpp"
#include "quadtune/physics/drone.hpp"
#include "quadtune/physics/world.hpp"
#include "quadtune/planning/local_planner.hpp"
#include "quadtune/planning/trajectory_backend.hpp"
#include "quadtune/sim/flight.hpp"
#include "quadtune/sim/replanner.hpp"

namespace quadtune::engine {

/// How a segment chooses its v_des.
enum class AdaptationMode {
  kOnline,        ///< BO over v_des, trials_per_segment trials (the paper's search)
  kContext,       ///< no trial: the policy's v_des for the free range at P_s sets every plan's
  kContextPrior,  ///< the policy's v_des as the first trial, then BO (trials_per_segment in all)
};
constexpr auto EnumNames(AdaptationMode) {
  return std::array{EnumName{AdaptationMode::kOnline, "online"},
                    EnumName{AdaptationMode::kContext, "context"},
                    EnumName{AdaptationMode::kContextPrior, "context_prior"}};
}

/// Settings of the online adaptation (YAML `adaptation:`).
struct AdaptationOptions {
  AdaptationMode mode = AdaptationMode::kOnline;  ///< how a segment chooses v_des
  /// w_r >= 0: weight of the stopping risk J_r (context_policy.hpp) added to a trial's f_s
  /// (1/m² in f_s units); 0 scores plans by the paper's terms only.
  double risk_weight = 0.0;
  double risk_range = 5.0;  ///< free distances searched up to this (m), > 0: the sensor's range
  /// τ >= 0 (s): J_r also asks for a clearance of τ |v| beyond the inflation (StoppingRisk).
  double risk_reaction_time = 0.0;
  /// The context policy (required by the context modes); its free-range measurement also gives
  /// every segment's recorded context.
  std::optional<ContextPolicy> policy;
  double lookahead = 2.0;       ///< R: arc length from a trajectory's start to P_s (m), (0, 20]
  double v_min = 1.0;           ///< lower bound of v_des (m/s), > 0
  double v_max = 6.0;           ///< upper bound of v_des (m/s), in (v_min, 15]
  int trials_per_segment = 8;   ///< BO trials per P_s, [1, 200]
  /// A segment needs at least this arc length of the trajectory after P_s (m), >= 0.
  double min_remaining = 1.0;
  /// Braking envelope of a plan that starts faster than its v_des (see the file comment), (0, 1].
  double braking_fraction = 0.5;
  /// f_s weights (kind changing_environment) and the failure value told for a failed trial.
  ObjectiveOptions objective = DefaultObjective();
  optimizers::BayesOptOptions bo = DefaultBayesOpt();  ///< its seed is replaced per segment
  std::uint64_t seed = 0;       ///< seed of every segment's BO

  /// The paper's weights: w_t 1, w_p 0.01, w_c 100, C 0.5 m; failure value 50.
  static ObjectiveOptions DefaultObjective();
  /// Three initial points, noise growing by 1 per second of age.
  static optimizers::BayesOptOptions DefaultBayesOpt();
  /// Throws ConfigError(file, "adaptation.<key>", allowed range) for the first bad field.
  void Validate(const std::string& file = "") const;
  /// Reads AdaptationFields over the defaults, then validates; unknown keys throw.
  static AdaptationOptions FromYaml(const YamlMap& map);
};

/// `adaptation:`: lookahead, v_des_bounds [lo, hi], trials_per_segment, min_remaining,
/// braking_fraction, objective (ObjectiveFields over DefaultObjective; short_term.kind must be
/// changing_environment) and bo (BayesOptOptions over DefaultBayesOpt; no seed).
const Fields<AdaptationOptions>& AdaptationFields();

/// One BO trial: a plan from P_s with one v_des, and its f_s terms.
struct AdaptationTrial {
  int segment = 0;         ///< segment index
  int trial = 0;           ///< index within the segment
  double time = 0.0;       ///< flight time at which it was planned (s)
  Eigen::Vector3d p_s_W = Eigen::Vector3d::Zero();  ///< P_s (m)
  double v_des = 0.0;      ///< proposed desired velocity (m/s)
  bool success = false;    ///< a plan was found and accepted
  std::string status;      ///< "success", "braking" (accepted by the envelope), a PlanStatus
                           ///< name, or "front_end"
  double t_exe = 0.0;      ///< duration of the plan (s)
  double jerk_integral = 0.0;  ///< ∫|jerk|² dt of the plan (m²/s⁵)
  double min_clearance = 0.0;  ///< c_obs: smallest distance-field value along the plan (m)
  double j_c = 0.0;        ///< J_c
  double j_r = 0.0;        ///< J_r, the stopping risk (m²); counted in f_s with risk_weight
  bool from_policy = false;  ///< its v_des came from the context policy, not from BO
  double f_s = 0.0;        ///< objective value (the failure value for a failed trial)
  double compute_units = 0.0;  ///< deterministic solve cost
  bool chosen = false;     ///< executed from P_s
};

/// One P_s and what became of it.
struct AdaptationSegment {
  enum class Outcome { kAdopted, kNoSuccess, kSuperseded };
  int index = 0;
  double t0 = 0.0;          ///< start time of the trajectory P_s lies on (s)
  double split_time = 0.0;  ///< t_s: time of P_s on that trajectory (s)
  Eigen::Vector3d p_s_W = Eigen::Vector3d::Zero();  ///< P_s (m)
  double speed_s = 0.0;     ///< reference speed at P_s (m/s)
  double v_des_before = 0.0;  ///< v_des in force when the segment started (m/s)
  /// Free range (m) measured at P_s along the segment's direction of motion at the first trial
  /// (the policy's measurement options, else FreeRangeOptions{}); -1 before it is measured.
  double free_range = -1.0;
  double policy_v_des = 0.0;  ///< the policy's v_des for it (context modes), else 0
  double v_des = 0.0;       ///< v_des in force after the segment (the chosen one when adopted)
  int trials = 0;           ///< trials run
  int successes = 0;        ///< successful trials
  int best_trial = -1;      ///< index of the chosen trial within the segment (-1: none)
  double best_f_s = 0.0;    ///< its f_s
  /// kAdopted: the best trial executes from P_s; kNoSuccess: no trial succeeded;
  /// kSuperseded: another trajectory (a collision re-plan) replaced the one P_s lay on.
  Outcome outcome = Outcome::kSuperseded;
};
constexpr auto EnumNames(AdaptationSegment::Outcome) {
  using Outcome = AdaptationSegment::Outcome;
  return std::array{EnumName{Outcome::kAdopted, "adopted"},
                    EnumName{Outcome::kNoSuccess, "no_success"},
                    EnumName{Outcome::kSuperseded, "superseded"}};
}

/// The adapter. See the file comment.
class OnlineAdapter final : public sim::PlanAdapter {
 public:
  /// Plans its trials with `backend` (the flight's; it must outlive the adapter), recording the
  /// snapshot the back end reads; the braking check takes its tolerance and sampling from
  /// planner_options.optimizer. Validates `options`.
  OnlineAdapter(const planning::TrajectoryBackend& backend,
                const sim::FlightPlannerOptions& planner_options, AdaptationOptions options);
  ~OnlineAdapter() override;
  OnlineAdapter(const OnlineAdapter&) = delete;
  OnlineAdapter& operator=(const OnlineAdapter&) = delete;

  void OnTrajectory(double t0, const planning::Trajectory& trajectory, bool reaches_waypoint,
                    const planning::PlannerParams& params) override;
  std::optional<sim::AdaptedPlan> OnTick(double t, const planning::LocalMap& map,
                                              const Eigen::Vector3d& waypoint_W) override;
  [[nodiscard]] bool HoldsPeriodicReplan() const override {
    return pending_ != nullptr && options_.mode != AdaptationMode::kContext;
  }

  /// Called with every segment once it is closed (for progress output). May be empty.
  void SetSegmentObserver(std::function<void(const AdaptationSegment&)> observer) {
    observer_ = std::move(observer);
  }

  [[nodiscard]] const std::vector<AdaptationTrial>& trials() const { return trials_; }
  [[nodiscard]] const std::vector<AdaptationSegment>& segments() const { return segments_; }
  [[nodiscard]] const AdaptationOptions& options() const { return options_; }
  /// In `context` mode, the policy's latest v_des (m/s): it stays in force for every plan,
  /// the FSM's re-plans included, until the next measurement (RunAdaptFlight installs it as
  /// the flight's parameter provider). nullopt before the first measurement and in the other
  /// modes.
  [[nodiscard]] std::optional<double> context_v_des() const { return context_v_des_; }

 private:
  struct Pending;
  void RunTrial(double t, const planning::LocalMap& map, const Eigen::Vector3d& waypoint_W);
  // Measures the context at P_s; in the context modes the policy's v_des there, else nullopt.
  std::optional<double> PolicyChoice(const planning::LocalMap& map);
  void Close(AdaptationSegment::Outcome outcome);

  const planning::TrajectoryBackend& backend_;
  planning::LocalPlanner planner_;
  planning::TrajectoryOptimizerOptions limits_;  // the braking check's tolerance and sampling
  AdaptationOptions options_;
  std::unique_ptr<Pending> pending_;
  std::vector<AdaptationTrial> trials_;
  std::vector<AdaptationSegment> segments_;
  std::function<void(const AdaptationSegment&)> observer_;
  std::optional<double> context_v_des_;
};

/// The changing-environment experiment file (`quadtune adapt`).
///
/// ```
/// name: changing_environment
/// seed: 5                       # layout, world and BO seeds
/// drone: drones/research_1kg.yaml
/// layout_file: layouts/changing_density.yaml   # generator options with density zones
/// world: {...}                  # optional physics::WorldOptions
/// max_time: 90                  # flight time limit (s)
/// planner: {type: ego, h_pl: 7.5, ...}  # optional: type (a closed-loop planner, default ipopt)
///                               # and PlannerParams over the defaults (v_des: the start value)
/// baselines: [2.0, 4.0]         # fixed v_des flown for comparison
/// adaptation: {lookahead: 2.0, v_des_bounds: [1, 6], trials_per_segment: 8, objective: ..., bo: ...}
/// ```
struct AdaptExperiment {
  std::string name = "changing_environment";
  std::string file;                   ///< where it was read from
  std::string base_dir = ".";         ///< folder relative paths resolve against (then assets/)
  std::uint64_t seed = 1;
  std::string drone_file;             ///< resolved path
  physics::DroneDescription drone;
  std::string layout_file;            ///< resolved path
  layout::LayoutOptions layout;
  physics::WorldOptions world;        ///< seed replaced by `seed`; pass-through collisions
  double max_time = 90.0;             ///< (s), > 0
  /// `planner.type`: a registered planner type flown in the closed loop (ClosedLoopPlanners());
  /// every flight flies its back end.
  std::string planner_type = "ipopt";
  planning::PlannerParams params;     ///< fixed parameters; v_des is the adapted flight's start
  std::vector<double> baselines{2.0}; ///< fixed v_des values (m/s), each in (0, 15]
  AdaptationOptions adaptation;
  /// The depth camera (`sensor:`, keys over sim::FlightOptions::DefaultSensor()).
  physics::DepthSensorOptions sensor = sim::FlightOptions::DefaultSensor();
  bool goal_braking = false;  ///< LocalPlannerOptions::goal_braking of every flight
  /// Zones whose spacing lies below this are "dense", the others "sparse" (m), > 0.
  double dense_below = 1.5;
  /// Corridor studies (`adapt --corridors N`): f_l = t_f + t_f·n_c + w_e·n_e of each flight,
  /// a flight that does not finish scoring failure_value.
  double w_e = 5.0;
  double failure_value = 1000.0;

  /// Reads and checks a file; errors name the file, the key and what is allowed (a
  /// `planner.type` that is not a closed-loop planner: key planner.type, listing those that are).
  static AdaptExperiment LoadFile(const std::string& path);
  /// As LoadFile, from text; relative paths are resolved against `base_dir`, then assets/.
  static AdaptExperiment FromString(const std::string& text, const std::string& origin,
                                    const std::string& base_dir = ".");
  /// Replaces the seed (and the adaptation's seed derived from it).
  void SetSeed(std::uint64_t new_seed);
};

/// The adaptation experiment file's keys (read into an AdaptExperiment whose `file` and
/// `base_dir` are set; FromString then sets the seeds).
const Fields<AdaptExperiment>& AdaptExperimentFields();

/// One flight of the experiment.
struct AdaptFlight {
  std::string label;        ///< "adapted" or "fixed_<v>"
  bool adapted = false;
  double v_des = 0.0;       ///< the fixed v_des, or the adapted flight's start value (m/s)
  sim::FlightResult result;
  std::vector<AdaptationTrial> trials;      ///< adapted flight only
  std::vector<AdaptationSegment> segments;  ///< adapted flight only
};

/// What one flight of the experiment flies: v_des adapted by the experiment's adaptation (with
/// `mode` in place of its mode when given), or a fixed v_des.
struct FlightPolicy {
  std::optional<double> fixed_v_des;          ///< a fixed v_des (m/s); empty: adapted
  std::optional<AdaptationMode> mode;         ///< the adapted flight's mode; empty: the file's
  /// "fixed_<v>"; for an adapted flight "context" when its mode is context, else "adapted".
  [[nodiscard]] std::string Label(const AdaptationOptions& adaptation) const;
};

/// Flies start → goal of `layout` once with the back end of `experiment.planner_type` under
/// `policy`. Deterministic for the same experiment, layout and seed. Flight failures are
/// reported in the result's metrics, never thrown.
[[nodiscard]] AdaptFlight RunAdaptFlight(
    const AdaptExperiment& experiment, const layout::Layout& layout, const FlightPolicy& policy,
    const std::function<void(const AdaptationSegment&)>& on_segment = {},
    const std::atomic<bool>* cancel = nullptr);

/// Flies start → goal of `layout` once with the back end of `experiment.planner_type`: adapted
/// (fixed_v_des empty) or with a fixed v_des.
/// Deterministic for the same experiment, layout and seed. Flight failures are reported in the
/// result's metrics, never thrown.
[[nodiscard]] AdaptFlight RunAdaptFlight(
    const AdaptExperiment& experiment, const layout::Layout& layout,
    std::optional<double> fixed_v_des,
    const std::function<void(const AdaptationSegment&)>& on_segment = {},
    const std::atomic<bool>* cancel = nullptr);

}  // namespace quadtune::engine
