#pragma once
/// \file
/// The corridor study of the changing-environment experiment (`quadtune adapt --corridors N`):
/// N corridors of changing density (the experiment's zoned layout with seeds first_seed …
/// first_seed + N − 1), each flown by every policy: the adapted flight (the experiment's
/// adaptation mode), the context policy alone (when the experiment has one and its mode is not
/// `context`), and every fixed v_des of `baselines`. Each flight is scored
/// f_l = t_f + t_f·n_c + w_e·n_e (failure_value when it does not finish).
///
/// The comparison holds a fixed v_des to the standard a user could reach without adaptation:
/// for corridor i, the "best fixed" v_des is the baseline with the lowest mean f_l over the
/// OTHER corridors (leave-one-out), and its f_l on corridor i is what the adapted flight must
/// beat. Dense zones are those of spacing below the experiment's `dense_below`.
///
/// Thread safety: RunCorridors flies corridors concurrently (ParallelFor over `threads`); the
/// progress callback is called under a lock. The other functions are pure.

#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "quadtune/engine/adaptation/online_adaptation.hpp"

namespace quadtune::engine {

/// One flight of the corridor study.
struct CorridorFlight {
  std::uint64_t corridor_seed = 0;
  std::string policy;        ///< "adapted", "context" or "fixed_<v>"
  std::string status;        ///< sim::FlightStatus name
  double f_l = 0.0;          ///< t_f + t_f·n_c + w_e·n_e, or the failure value
  double flight_time = 0.0;  ///< t_f (s)
  int collisions = 0;        ///< n_c
  int emergency_stops = 0;   ///< n_e
  double mean_speed = 0.0;   ///< (m/s)
  /// Time-weighted mean v_des in force while the drone was over dense / sparse zones (m/s);
  /// 0 when it spent no time there.
  double v_des_dense = 0.0;
  double v_des_sparse = 0.0;
  int segments = 0;  ///< adaptation segments (adapted flights)
};

/// Index of the zone of `options` holding x (the last zone also takes its upper end), or -1.
[[nodiscard]] int ZoneIndex(const layout::LayoutOptions& options, double x);

/// Time-weighted mean v_des in force over the dense and the sparse zones of `options` along the
/// flight's log (first: dense, second: sparse; 0 where no time was spent).
[[nodiscard]] std::pair<double, double> DenseSparseVDes(const sim::FlightResult& flight,
                                                        const layout::LayoutOptions& options,
                                                        double dense_below);

/// f_l of a flight with the experiment's w_e and failure value.
[[nodiscard]] double CorridorFl(const sim::FlightMetrics& metrics, const AdaptExperiment& e);

/// Which corridors to fly.
struct CorridorOptions {
  std::uint64_t first_seed = 101;  ///< seed of the first corridor
  int count = 10;                  ///< corridors, >= 1
  int threads = 1;                 ///< flights flown at once, >= 1
};

/// The policies the study flies for `e` (see the file comment), in order.
[[nodiscard]] std::vector<FlightPolicy> CorridorPolicies(const AdaptExperiment& e);

/// Flies every corridor with every policy; rows ordered by corridor, then policy. `progress`
/// (may be empty) sees each row as it finishes, with the count done and the total. Throws
/// Cancelled (quadtune/common/cancel.hpp) when `cancel` is set.
[[nodiscard]] std::vector<CorridorFlight> RunCorridors(
    const AdaptExperiment& e, const CorridorOptions& options,
    const std::function<void(const CorridorFlight&, int done, int total)>& progress = {},
    const std::atomic<bool>* cancel = nullptr);

/// One corridor's verdict.
struct CorridorVerdict {
  std::uint64_t corridor_seed = 0;
  std::string best_fixed;         ///< the leave-one-out best fixed policy
  double best_fixed_f_l = 0.0;    ///< its f_l here
  int best_fixed_collisions = 0;  ///< its collisions here
};

/// The study's comparison.
struct CorridorComparison {
  std::vector<CorridorVerdict> corridors;
  /// Per adaptive policy ("adapted", "context"): mean f_l, total collisions, and on how many
  /// corridors v_des_dense < v_des_sparse.
  struct Adaptive {
    std::string policy;
    double mean_f_l = 0.0;
    int collisions = 0;
    int lower_in_dense = 0;
    int corridors = 0;
  };
  std::vector<Adaptive> adaptive;
  double best_fixed_mean_f_l = 0.0;  ///< mean over corridors of the leave-one-out best fixed
  int best_fixed_collisions = 0;
};

/// Compares the rows of RunCorridors. Needs at least two corridors and one fixed policy for the
/// leave-one-out choice (else `corridors` is empty).
[[nodiscard]] CorridorComparison CompareCorridors(const std::vector<CorridorFlight>& rows);

/// One density of a density study, as the context policy learns from it.
struct DensityPoint {
  std::string label;             ///< the study's label, e.g. "0.9"
  layout::LayoutOptions layout;  ///< the density's forest
  double v_des = 0.0;            ///< the tuned v_des there (m/s)
};

/// One v_des of the grid flown on one density's forest (ChooseVDesByGrid).
struct GridCell {
  std::string label;      ///< the density's label
  double v_des = 0.0;     ///< the fixed v_des flown (m/s)
  int flights = 0;        ///< maps flown
  double mean_f_l = 0.0;  ///< mean corridor f_l over them
  int collisions = 0;     ///< n_c summed over them
  int unfinished = 0;     ///< flights that did not finish
  bool chosen = false;    ///< the density's v_des
};

/// The library of parameter sets, by a grid: every v_des of `grid` flies each density's forest
/// as fixed v_des (go-to over the forest, seeds e.seed … e.seed + maps − 1, the experiment's
/// planner and drone). A density's v_des becomes the one with the lowest mean f_l among those
/// whose flights all finished without a collision, or the lowest mean f_l when none did. Sets
/// densities[i].v_des and returns every cell, by density then grid order. Throws ConfigError
/// (origin "policy", key "grid") for an empty grid or a v_des outside the adaptation's bounds.
[[nodiscard]] std::vector<GridCell> ChooseVDesByGrid(const AdaptExperiment& e,
                                                     std::vector<DensityPoint>& densities,
                                                     const std::vector<double>& grid, int maps,
                                                     int threads);

/// Learns a ContextPolicy: each density's forest is flown on `maps` maps (seeds
/// e.seed … e.seed + maps − 1, go-to over the forest) with the adaptation in mode `context` at
/// the density's own v_des (a one-point policy), and the mean free range measured at the
/// segments' P_s becomes the density's context. Points are sorted by free range; two densities
/// whose mean free ranges do not differ keep the first. Throws ConfigError when fewer than two
/// distinct points remain.
[[nodiscard]] ContextPolicy LearnContextPolicy(const AdaptExperiment& e,
                                               const std::vector<DensityPoint>& densities, int maps,
                                               int threads);

}  // namespace quadtune::engine
