#pragma once
/// \file
/// An experiment: one YAML file that says which planner flies where, which parameters are
/// short- or long-term and their bounds, the objective weights, the methods compared, budgets,
/// repeats, seed, threads and timing mode. Loading checks everything before any work starts;
/// every error is a ConfigError naming the file, the key and what is allowed.
///
///     name: tiny
///     seed: 1                  # master seed; every stream derives from it
///     threads: 2               # worker threads (the CLI's --threads overrides)
///     mode: reproducible       # reproducible | realtime
///     repeats: 1               # trials per method
///     maps:                    # which map each flight flies (common random numbers: flight k of
///       mode: per_flight       # every method in repeat r flies the same map)
///                              # per_flight: a fresh map per flight | per_repeat: one map per
///                              # repeat | pool: flight k flies map k mod pool of the repeat
///       pool: 10               # pool mode: maps per repeat, >= 1
///     validation:              # held-out validation after the trials (`quadtune run`)
///       maps: 20               # maps no trial flies; each method's recommended point and the
///                              # defaults fly all of them (0: no validation)
///     recommend:               # how a trial picks the point it hands back (after its budget)
///       candidates: 6          # best-ranked points tried in turn (bo, bo_pso: lowest posterior
///                              # mean first; random, pso: lowest f_l first); 0: the first, unflown
///       flights: 5             # re-flights of a candidate on fresh maps (the same for every
///                              # method of a repeat; disjoint from tuning and held-out maps)
///       clearance: 0.0         # m and z: a candidate passes when every re-flight completes
///       z: 2.33                # without a collision and the re-flights' smallest clearances c
///                              # keep mean(c) − z·sd(c) >= clearance; none passes: the defaults
///       emergency_stops: false # false: a re-flight with an emergency stop fails its candidate
///       backoff: 0             # then this many points between the best candidate and the defaults
///     race:                  # racing against an incumbent during tuning (optimizers/racing.hpp)
///       enabled: false         # true: challengers race the incumbent (at first the defaults) on
///       first_maps: 4          # shared race maps; the trial hands back its incumbent
///       max_maps: 12           # (recommend.candidates must be 0); a winner flies max_maps;
///       alpha: 0.05            # every race flight counts against budget.flights
///       share: 0.5             # race after a round while race flights stay <= share × flights
///       tell: true             # race flights become observations of bo's / bo_pso's GP
///     methods: [default, random, pso, bo, bo_pso]
///     planner:
///       type: ipopt            # a registered planner (planner_registry.hpp): ipopt | ego | …
///       drone: drones/research_1kg.yaml        # ipopt: relative to the file, then assets/
///       layout: {spacing: 3.0, ...}            # ipopt: LayoutOptions, or layout_file: PATH
///       world: {...}                           # ipopt: WorldOptions (seed set per flight)
///       mission: go_and_return                 # ipopt: go_and_return | go_to
///       max_time: 60                           # ipopt: flight time limit (s)
///       fixed: {a_max: 3.0}                    # ipopt: fixed PlannerParams
///       safety_nets: true                      # ipopt: false plans as the paper's planners do:
///                              # one attempt per re-plan, no 10× collision-weight retries, no
///                              # stop-and-go fallback
///     parameters:              # ParameterSpace (bounds, log, integer, default)
///       - {name: w_col, lower: 0.05, upper: 5.0, log: true, default: 0.5}
///     short_term: [w_col, w_dyn, n_pol]        # θ_s (PSO in bo_pso)
///     long_term: [v_des, h_pl, t_pl]           # θ_l (BO in bo_pso)
///     initial_short_term: {w_col: 0.5, ...}    # optional: skip the first θ_s phase
///     start: {v_des: 2.4, w_col: 0.8, ...}     # optional: a known good point (refinement,
///                              # paper Sec. III-E): BO searches first inside
///                              # start ± bo.moving_bounds.half_width, bo_pso's PSO starts from it
///     objective: {short_term: {...}, long_term: {w_e: 5}, failure_value: 1000}
///     budget:
///       flights: 6             # f_l evaluations per trial, >= 1
///       default_flights: 5     # flights of method `default` (absent: flights)
///       flight_batch: 2        # flights asked and flown together, >= 1 (fixed: not the threads);
///                              # 0 in realtime mode: one per thread
///       short_evals_per_flight: 40   # θ_s candidates (PSO) per flight (paper ≈ 3500 re-solves)
///       queries_per_eval: 4    # recorded queries re-solved per θ_s candidate, >= 1
///       query_window: 200      # most recent recorded queries kept, >= 1
///       short_term_while_flying: false  # realtime only: PSO uses the whole flight time
///     pso: {num_particles: 8, ...}             # PsoOptions (seed derived per trial)
///     bo: {initial_design_size: 3, ...}        # BayesOptOptions (seed derived per trial)
///
/// Room engine/experiment: its files include engine headers of this room, api and planners only
/// (scripts/check_rooms.py; docs/design.md, "Architecture").
///
/// Thread safety: an Experiment is an immutable value after loading. SetAssetDirs is not
/// synchronised: call it before any thread loads a file.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "quadtune/common/fields.hpp"
#include "quadtune/engine/api/asset_paths.hpp"
#include "quadtune/engine/api/planner.hpp"
#include "quadtune/engine/experiment/method.hpp"
#include "quadtune/engine/experiment/objectives.hpp"
#include "quadtune/engine/planners/planners.hpp"
#include "quadtune/optimizers/bayes_opt.hpp"
#include "quadtune/optimizers/parameter_space.hpp"
#include "quadtune/optimizers/pso.hpp"
#include "quadtune/optimizers/racing.hpp"

namespace quadtune::engine {


/// Which map a flight flies (YAML `maps.mode`).
enum class MapMode {
  kPerFlight,  ///< every flight a fresh map of the layout's density (the default)
  kPerRepeat,  ///< one map per repeat, flown by every flight of its trials
  kPool,       ///< a pool of `maps.pool` maps per repeat; flight k flies map k mod pool
};
constexpr auto EnumNames(MapMode) {
  return std::array{EnumName{MapMode::kPerFlight, "per_flight"},
                    EnumName{MapMode::kPerRepeat, "per_repeat"}, EnumName{MapMode::kPool, "pool"}};
}

/// YAML `maps:`.
struct MapOptions {
  MapMode mode = MapMode::kPerFlight;
  int pool = 10;  ///< kPool: maps per repeat, >= 1
};

/// YAML `validation:`: the held-out validation that ends `quadtune run`.
struct ValidationOptions {
  int maps = 20;  ///< held-out maps, >= 0 (0: none)
};

/// YAML `recommend:`: the re-flights that pick a trial's recommended point (tuner.cpp).
struct RecommendOptions {
  int candidates = 0;       ///< >= 0 ranked candidates tried in turn; 0: the top-ranked, unchecked
  int flights = 5;          ///< >= 1 re-flights per candidate
  /// A candidate passes when every re-flight completes without a collision and the smallest
  /// clearances c of its re-flights keep mean(c) − z·sd(c) >= clearance: under a normal fit of c,
  /// a collision (c < 0) on a new map has probability below Φ(−z) (2.33: 1%).
  double clearance = 0.0;  ///< >= 0 m
  double z = 2.33;         ///< >= 0
  /// false: a re-flight with an emergency stop fails the candidate (the precursor of most
  /// collisions on new maps); true: emergency stops are allowed.
  bool emergency_stops = false;
  /// >= 0 back-off candidates tried after the ranked ones: the best candidate moved towards the
  /// defaults, u_d + α (u_best − u_d) in the unit cube, α = 1 − i / (backoff + 1), i = 1 … backoff.
  int backoff = 0;
};

/// Caps on budgets, generous but finite: a file asking for more is refused when it loads
/// (a run that could never finish is a mistake, not a plan).
inline constexpr int kMaxFlights = 100000;            ///< budget.flights, default_flights
inline constexpr int kMaxRepeats = 1000;              ///< repeats
inline constexpr double kMaxTotalFlights = 1.0e7;     ///< flights × methods × repeats per run
inline constexpr int kMaxShortEvalsPerFlight = 100000;  ///< budget.short_evals_per_flight
/// threads, and every command's --threads: worker threads of one process.
inline constexpr int kMaxThreads = 1024;

/// Budgets of one trial (YAML `budget:`).
struct Budget {
  int flights = 6;                 ///< long-term evaluations per trial, in [1, kMaxFlights]
  /// Flights of the `default` method (paper: the average of five flights with the defaults);
  /// absent in YAML → `flights`.
  int default_flights = 6;
  /// Flights asked and flown together, >= 1; 0 (realtime mode only): one per worker thread
  /// ("ask for as many candidates as there are free worlds").
  int flight_batch = 2;
  int short_evals_per_flight = 40; ///< θ_s candidates per flight (bo_pso), >= 0
  int queries_per_eval = 4;        ///< queries re-solved per θ_s candidate, >= 1
  int query_window = 200;          ///< recorded queries kept (most recent), >= 1
  /// Realtime mode only: after its short_evals_per_flight × flights evaluations, PSO keeps
  /// running generations until the round's flights have landed (a wall-time share, as in the
  /// paper's background optimisation). Not reproducible, so rejected in reproducible mode.
  bool short_term_while_flying = false;
};

/// A loaded, checked experiment.
struct Experiment {
  std::string file;        ///< where it came from ("<string>" for text)
  std::string text;        ///< the full configuration text (stored with the results)
  std::string base_dir = ".";  ///< folder the file's relative paths resolve against
  std::string name = "experiment";
  std::uint64_t seed = 1;
  int threads = 2;         ///< >= 1
  TimingMode mode = TimingMode::kReproducible;
  int repeats = 1;         ///< >= 1
  std::vector<Method> methods;
  std::string planner_type;  ///< the registered `planner.type` (planner_registry.hpp)
  Planner planner{NoPlanner{}};  ///< the plug-in (NoPlanner until the `planner:` map is read)
  optimizers::ParameterSpace space;  ///< all tuned parameters
  std::vector<std::string> short_names;  ///< θ_s, in space order
  std::vector<std::string> long_names;   ///< θ_l, in space order
  std::optional<ParamValues> initial_short;  ///< given θ_s (bo_pso skips its first phase)
  /// A known good point (YAML `start:`, any subset of the tuned parameters; the others keep their
  /// defaults). With bo.moving_bounds.enabled, methods bo and bo_pso (its BO on θ_l) begin inside
  /// start ± half_width (unit-cube widths), then the bounds move with the best point; bo_pso's θ_s
  /// starts from start's short-term part. Used to refine a result in a higher-fidelity world.
  std::optional<ParamValues> start;
  ObjectiveOptions objective;
  MapOptions maps;
  ValidationOptions validation;
  RecommendOptions recommend;
  optimizers::RaceOptions race;
  Budget budget;
  optimizers::PsoOptions pso;
  optimizers::BayesOptOptions bo;

  /// Reads and checks a file (relative paths inside resolve against its folder, then assets/).
  static Experiment LoadFile(const std::string& path);
  /// As LoadFile, with "dotted.key=value" assignments (`quadtune run --set`) applied to the
  /// file's text first (ApplyAssignments); the stored configuration is the edited text.
  static Experiment LoadFile(const std::string& path, const std::vector<std::string>& assignments);
  /// Reads and checks text; `origin` names it in errors, `base_dir` resolves relative paths.
  static Experiment FromString(const std::string& text, const std::string& origin = "<string>",
                               const std::string& base_dir = ".");

  /// Map seed of repeat r: the map of every flight in per_repeat mode, and the one prepared (and
  /// so checked) before any work in the other modes.
  [[nodiscard]] std::uint64_t MapSeed(int repeat) const;
  /// Map seed of flight `flight` (0, 1, … in the order a trial flies them) of repeat `repeat`,
  /// by maps.mode. It does not depend on the method: flight k of every method flies one map.
  [[nodiscard]] std::uint64_t FlightMapSeed(int repeat, int flight) const;
  /// Seed of re-flight map `index` of repeat `repeat` (RecommendOptions), the same for every
  /// method; derived under a tag no tuning or held-out map uses.
  [[nodiscard]] std::uint64_t RecheckMapSeed(int repeat, int index) const;
  /// Seed of the world's random streams for re-flight `index` of repeat `repeat`.
  [[nodiscard]] std::uint64_t RecheckFlightSeed(int repeat, int index) const;
  /// Seed of race map `index` of repeat `repeat` (racing, the same for every method and for
  /// incumbent and challenger); derived under a tag no other map uses.
  [[nodiscard]] std::uint64_t RaceMapSeed(int repeat, int index) const;
  /// Seed of the world's random streams on race map `index` of repeat `repeat`.
  [[nodiscard]] std::uint64_t RaceFlightSeed(int repeat, int index) const;
  /// Seed of held-out map `index` (validation). Derived under a tag no tuning map uses.
  [[nodiscard]] std::uint64_t HeldOutMapSeed(int index) const;
  /// Seed of the world's random streams for the validation flights on held-out map `index`
  /// (the same for every parameter set flown there).
  [[nodiscard]] std::uint64_t HeldOutFlightSeed(int index) const;
  /// Every parameter the planner takes at its default, overridden by the space's defaults.
  [[nodiscard]] ParamValues Defaults() const;
};

/// The experiment file's top level (ExperimentFields reads it into an Experiment whose `file`,
/// `text` and `base_dir` are set), and its sections: `maps:`, `validation:`, `recommend:`,
/// `budget:` (budget's checks against mode, methods and repeats are made at the top level).
const Fields<Experiment>& ExperimentFields();
const Fields<MapOptions>& MapsFields();
const Fields<ValidationOptions>& ValidationFields();
const Fields<RecommendOptions>& RecommendFields();
const Fields<Budget>& BudgetFields();

}  // namespace quadtune::engine
