#pragma once
/// \file
/// The sweep experiment: variance-based parameter importance (Sobol' indices) of an experiment's
/// objectives over its parameter box.
///
/// Design (Saltelli 2010): a 2d-dimensional Sobol' sequence (Boost.Random's `sobol`, first point
/// after the origin) with a seeded random digital shift (each coordinate's 64 bits XORed with a
/// per-dimension random word, which keeps the net's equidistribution) gives two N × d unit-cube
/// matrices A (first d columns) and B (last d). The N·(d + 2) design points are the rows of A,
/// of B and of every A_B^(i) (A with column i taken from B). Unit coordinates map to parameter
/// values through ParameterSpace::FromUnit (log scales, integer cells) and ToNamed.
///
/// Flights: every point flies on the same K maps (map seeds DeriveSeed(seed, {0x3a, k}), made by
/// planner.PrepareMap), flight seed DeriveSeed(seed, {0xf1, point, k}), with the point's θ_s and
/// θ_l over the experiment's defaults; f_l = LongTermObjective (all terms kept). A failed flight
/// is recorded (status, message; f_l = objective.failure_value) and never stops the sweep.
///
/// Short-term objective: K flights at the defaults (seeds DeriveSeed(seed, {0xde, k})) record
/// planning queries on the same K maps; a fixed subset of Q of them (seeded draw without
/// replacement, in recording order: map 0's first) is re-solved with each distinct θ_s of the
/// design; f_s of a point = the mean ShortTermObjective over the subset (a failed re-solve
/// scores failure_value). f_s depends on θ_s only: design points that differ only in θ_l share
/// their re-solves, so f_s's indices of the θ_l parameters are exactly 0 by construction.
///
/// Indices per output (f_l averaged over the K maps, its terms t_f, n_c, n_e averaged likewise,
/// and f_s): first-order S_i by the Saltelli (2010) estimator, total-effect ST_i by Jansen's,
/// with percentile bootstrap confidence intervals from seeded resampling of the N base rows.
/// An output with zero variance over A and B has no indices (NaN).
///
/// Determinism: flights and re-solves run concurrently on the engine's Scheduler and WorldPool;
/// results are gathered by index, so the same seed gives identical results at any thread count
/// (in the experiment's reproducible mode, where t_c comes from compute units).
///
/// Thread safety: the pure functions are reentrant; RunSweep is driven by one thread (its
/// progress callback runs on that thread) and uses `threads` workers.

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "quadtune/engine/experiment/experiment.hpp"
#include "quadtune/engine/tuning/tuner.hpp"

namespace quadtune::engine {

/// The Saltelli design in unit coordinates: N base rows of A and B (N × d each).
struct SaltelliDesign {
  Eigen::MatrixXd a;
  Eigen::MatrixXd b;
  [[nodiscard]] int Rows() const { return static_cast<int>(a.rows()); }
  [[nodiscard]] int Dim() const { return static_cast<int>(a.cols()); }
  /// Number of design points, N·(d + 2).
  [[nodiscard]] int Points() const { return Rows() * (Dim() + 2); }
  /// Design point p in unit coordinates. Points are ordered block by block: block 0 = A,
  /// block 1 = B, block 2 + i = A_B^(i); p = block · N + row.
  [[nodiscard]] Eigen::VectorXd Point(int p) const;
  /// Block of point p (0 = A, 1 = B, 2 + i = A_B^(i)) and its base row.
  [[nodiscard]] int Block(int p) const { return p / Rows(); }
  [[nodiscard]] int Row(int p) const { return p % Rows(); }
};

/// Sobol'-based Saltelli design of `n` >= 1 base rows in `d` >= 1 dimensions; `seed` drives the
/// digital shift (seed 0: no shift, the plain sequence). Throws ConfigError when d exceeds
/// Boost's Sobol' tables (2d <= 3667).
SaltelliDesign MakeSaltelliDesign(int n, int d, std::uint64_t seed);

/// One parameter's indices with their bootstrap confidence intervals.
struct SobolIndex {
  double s1 = 0.0, s1_lo = 0.0, s1_hi = 0.0;  ///< first order and its interval
  double st = 0.0, st_lo = 0.0, st_hi = 0.0;  ///< total effect and its interval
};

/// Indices of one output.
struct SobolIndices {
  double mean = 0.0;      ///< mean of f over A and B
  double variance = 0.0;  ///< variance of f over A and B (population), the indices' denominator
  std::vector<SobolIndex> index;  ///< one per parameter (all NaN when variance is 0)
};

/// Estimates first-order (Saltelli 2010: S_i = mean(f_B (f_AB_i − f_A)) / V) and total-effect
/// (Jansen: ST_i = mean((f_A − f_AB_i)²) / 2V) indices, V the variance of f over A and B
/// together, from f_a and f_b (N values each) and f_ab (d vectors of N values: f at A_B^(i)).
/// Confidence intervals: `bootstrap` resamples (>= 1; with replacement, of the N base rows, seeded)
/// and their `confidence`-level percentile interval. Pure; throws std::invalid_argument on
/// mismatched sizes or N < 2.
SobolIndices EstimateSobolIndices(const std::vector<double>& f_a, const std::vector<double>& f_b,
                                  const std::vector<std::vector<double>>& f_ab, int bootstrap,
                                  std::uint64_t seed, double confidence = 0.95);

/// Spearman's rank correlation of x and y (ties get their mean rank); NaN when either is constant
/// or they have fewer than 2 entries. Throws std::invalid_argument on different sizes.
double SpearmanCorrelation(const std::vector<double>& x, const std::vector<double>& y);

/// Progress of a sweep (reported by RunSweep on its calling thread).
struct SweepProgress {
  int flights_done = 0, flights_total = 0;  ///< design flights (not the recording ones)
  long resolves_done = 0, resolves_total = 0;
  double elapsed_s = 0.0;
};

/// How to sweep.
struct SweepOptions {
  int points = 64;         ///< N base rows, >= 2
  int maps = 2;            ///< K maps every point flies on, >= 1
  int queries = 32;        ///< Q recorded queries re-solved per θ_s, >= 1
  std::uint64_t seed = 1;  ///< every stream of the sweep derives from it
  int threads = 2;         ///< worker threads, >= 1
  int bootstrap = 1000;    ///< bootstrap resamples for the intervals, >= 1
  std::function<void(const SweepProgress&)> on_progress;  ///< may be empty
  const std::atomic<bool>* cancel = nullptr;              ///< set → skip the jobs not started
  /// A journal file ("" = none): every flight and re-solve that finishes is appended to it as one
  /// JSON line (after a header naming the sweep); when the file exists, the evaluations it holds
  /// are taken from it instead of being run again, so an interrupted sweep resumes to the same
  /// result (reproducible mode). A journal of another sweep throws ConfigError.
  std::string journal;
};

/// One flight of the design.
struct SweepFlight {
  int point = 0;
  int map = 0;
  ObjectiveValue objective;  ///< f_l and its terms
  EvalStatus status = EvalStatus::kOk;
  std::string message;
  std::uint64_t map_seed = 0;
  std::uint64_t flight_seed = 0;
};

/// One design point.
struct SweepPoint {
  int block = 0, row = 0;               ///< see SaltelliDesign::Point
  ParamValues params;                   ///< the point's tuned parameters (names of the space)
  double f_l = 0.0;                     ///< mean f_l over the K maps
  std::map<std::string, double> terms;  ///< mean of each f_l term over the K maps
  int failed_flights = 0;
  double f_s = 0.0;  ///< mean f_s over the Q queries
  std::map<std::string, double> short_terms;  ///< mean of each f_s term over the Q queries
  int failed_resolves = 0;
};

/// How well one candidate short-term score tracks f_l (the paper asks that f_s and f_l "share
/// consistent tendency").
struct ShortTermAgreement {
  std::string name;      ///< "f_s" or an f_s term: t_c, n_s, t_exe, jerk_integral, J_c, …
  double spearman = 0.0; ///< rank correlation with mean f_l over every design point
  /// Rank correlation of the changes Δscore and Δf_l between each base row A and its AB_i for
  /// the short-term parameters i: the points differ in one θ_s parameter only, so this is what
  /// PSO's tendency does to f_l with θ_l held fixed. NaN without a short-term parameter.
  double spearman_short_changes = 0.0;
  int pairs = 0;         ///< the (A, AB_i) pairs behind spearman_short_changes
};

/// Indices of one output over all parameters (space order).
struct SweepOutput {
  std::string name;  ///< "f_l", "t_f", "n_c", "n_e", "f_s"
  SobolIndices indices;
};

/// The outcome of a sweep.
struct SweepResult {
  RunStatus status = RunStatus::kCompleted;
  std::vector<std::string> names;        ///< parameters, space order
  std::vector<std::uint64_t> map_seeds;  ///< the K maps
  std::vector<SweepFlight> flights;      ///< point-major: flights[point · K + map]
  std::vector<SweepPoint> points;        ///< N·(d + 2)
  std::vector<SweepOutput> outputs;      ///< f_l, its terms, f_s
  double spearman_fs_fl = 0.0;           ///< rank correlation of f_s and mean f_l over points
  std::vector<ShortTermAgreement> agreement;  ///< f_s, then each f_s term
  int queries_recorded = 0;              ///< by the K flights at the defaults
  int queries_used = 0;                  ///< min(Q, recorded)
  int distinct_short = 0;                ///< distinct θ_s re-solved
  long resolves = 0;
  double wall_s = 0.0;
};

/// Outputs whose indices RunSweep estimates, in order: f_l, its terms, f_s.
const std::vector<std::string>& SweepOutputNames();

/// Flights of one sweep on one layout, N·(d+2)·K: every flight is queued at once and its record
/// kept in memory.
inline constexpr double kMaxSweepFlights = 1.0e6;
/// Re-solves of one sweep on one layout, at most N·(d+2)·Q: each has a queued task and a result
/// slot in memory.
inline constexpr double kMaxSweepResolves = 1.0e7;

/// Throws ConfigError naming the option (`--points`, `--maps`, `--queries`, `--threads`,
/// `--bootstrap`), its value and what is allowed, for options out of range or a design of `dims`
/// parameters past kMaxSweepFlights or kMaxSweepResolves (computed without overflow).
void CheckSweepOptions(const SweepOptions& options, int dims);

/// Runs the sweep (see the file comment). Options out of range (CheckSweepOptions) throw
/// ConfigError naming the option; flight and re-solve failures are recorded, never thrown. Cancelled (options.cancel)
/// → status kCancelled and no indices.
SweepResult RunSweep(const Experiment& experiment, const SweepOptions& options);

}  // namespace quadtune::engine
