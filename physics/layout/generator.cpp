#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "delaunay_index.hpp"
#include "footprint_grid.hpp"
#include "quadtune/common/cancel.hpp"
#include "quadtune/common/error.hpp"
#include "quadtune/common/random.hpp"
#include "quadtune/layout/footprint.hpp"
#include "quadtune/layout/layout.hpp"

namespace quadtune::layout {
namespace {

using physics::CylinderObstacle;
using physics::ObstacleSet;
using physics::RingObstacle;

double Draw(Rng& rng, const Interval& iv) { return Uniform(rng, iv.min, iv.max); }

// One candidate obstacle of a zone, with its footprint.
struct Candidate {
  bool is_ring = false;
  CylinderObstacle cylinder;
  RingObstacle ring;
  Footprint footprint;
};

// Draws the kind and the shape (centre at the origin). The number of random draws depends only
// on the kind, so the stream stays reproducible.
Candidate DrawShape(const ObstacleMix& mix, Rng& rng) {
  Candidate c;
  c.is_ring = Uniform01(rng) < mix.ring_fraction;
  if (c.is_ring) {
    c.ring.radius = Draw(rng, mix.ring.radius);
    c.ring.thickness = Draw(rng, mix.ring.thickness);
    const double height = Draw(rng, mix.ring.center_height);
    c.ring.yaw = Draw(rng, mix.ring.yaw);
    // A rim that would cut the ground is raised until the ring stands on it.
    c.ring.center_W = {0.0, 0.0, std::max(height, c.ring.radius + 0.5 * c.ring.thickness)};
    c.footprint = FootprintOf(c.ring);
  } else {
    c.cylinder.radius = Draw(rng, mix.cylinder.radius);
    c.cylinder.z_min = 0.0;
    c.cylinder.z_max = Draw(rng, mix.cylinder.height);
    c.cylinder.center_W.setZero();
    c.footprint = FootprintOf(c.cylinder);
  }
  return c;
}

void MoveTo(Candidate& c, const Eigen::Vector2d& p_W) {
  c.footprint.a_W += p_W;
  c.footprint.b_W += p_W;
  if (c.is_ring) {
    c.ring.center_W.head<2>() = p_W;
  } else {
    c.cylinder.center_W = p_W;
  }
}

std::string Num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

struct ZoneResult {
  std::size_t darts = 0;
  double incremental_mean = 0.0;  // the mean the generator tracked, checked against a re-measure
  std::size_t count = 0;
};

// The zone's mean nearest-neighbour statistic, tracked incrementally: the centre distance
// (Delaunay conflict zone: only the new point's neighbours change their NN) or the free gap
// between footprints (every zone footprint is a candidate neighbour).
class MeanTracker {
 public:
  explicit MeanTracker(bool free_gap) : free_gap_(free_gap) {}

  std::size_t size() const { return values_.size(); }
  double sum() const { return sum_; }
  double mean() const { return sum_ / static_cast<double>(values_.size()); }

  // The zone's sum with `c` added (0 with fewer than two obstacles).
  double Predict(const Candidate& c, const Eigen::Vector2d& p, const detail::DelaunayIndex& index) {
    const std::size_t n = values_.size();
    candidate_.clear();
    if (free_gap_) {
      for (std::size_t i = 0; i < n; ++i) {
        candidate_.emplace_back(i, FootprintGap(c.footprint, footprints_[i]));
      }
    } else {
      index.PotentialNeighbours(p, candidate_);
    }
    own_ = std::numeric_limits<double>::infinity();
    double new_sum = sum_;
    for (const auto& [id, d] : candidate_) {
      own_ = std::min(own_, d);
      if (n >= 2 && d < values_[id]) new_sum -= values_[id] - d;
    }
    return n == 0 ? 0.0 : (n == 1 ? 2.0 * own_ : new_sum + own_);
  }

  // Accepts the candidate last passed to Predict, whose predicted sum was `new_sum`.
  void Accept(const Candidate& c, double new_sum) {
    for (const auto& [id, d] : candidate_) values_[id] = std::min(values_[id], d);
    values_.push_back(own_);
    footprints_.push_back(c.footprint);
    sum_ = new_sum;
  }

 private:
  bool free_gap_;
  std::vector<double> values_;  // NN statistic of every zone obstacle so far (m)
  std::vector<Footprint> footprints_;
  double sum_ = 0.0;
  double own_ = 0.0;
  std::vector<detail::DelaunayIndex::Neighbour> candidate_;
};

[[noreturn]] void ThrowImpossibleZone(const LayoutOptions& o, const ZoneOptions& zone,
                                      const std::string& spacing_key, const MeanTracker& tracker) {
  const std::size_t n = tracker.size();
  const std::string where = " in the zone x in [" + Num(zone.x_min) + ", " + Num(zone.x_max) + ")";
  const std::string advice =
      " candidates were all rejected (overlap within min_gap, keep-out zones, hard_core_ratio" +
      std::string(o.density == DensityDefinition::kArea ? ")" : ", or overshooting the target)") +
      "; use a larger spacing, smaller obstacles, a smaller min_gap or hard_core_ratio, or "
      "fewer/smaller keep-out zones";
  if (o.density == DensityDefinition::kArea) {
    throw ConfigError("", spacing_key,
                      "cannot place the " + Num(o.TargetCount(zone)) + " obstacles that spacing " +
                          Num(zone.spacing) + " m asks for" + where + " (area / (4 spacing²) of " +
                          Num(o.ZoneArea(zone)) + " m²): " + std::to_string(n) +
                          " placed, then the last " + std::to_string(o.max_rejections) + advice);
  }
  const std::string what = o.density == DensityDefinition::kFreeGap
                               ? "mean nearest-neighbour free gap"
                               : "mean nearest-neighbour spacing";
  throw ConfigError("", spacing_key,
                    "cannot reach the target spacing of " + Num(zone.spacing) + " m: with " +
                        std::to_string(n) + " obstacles" + where + " the " + what + " is " +
                        (n >= 2 ? Num(tracker.mean()) + " m" : std::string("undefined")) +
                        " and the last " + std::to_string(o.max_rejections) + advice);
}

// Fewest obstacles a zone may stop at under the mean-statistic definitions: half the count of a
// Poisson forest of that centre spacing (the free gap's centre spacing adds the mix's reach).
std::size_t MinimumCount(const LayoutOptions& o, const ZoneOptions& zone) {
  const double centre = o.density == DensityDefinition::kFreeGap
                            ? zone.spacing + o.MixOf(zone).MaxReach()
                            : zone.spacing;
  return std::max<std::size_t>(
      2, static_cast<std::size_t>(std::floor(0.5 * o.ZoneArea(zone) / (4.0 * centre * centre))));
}

// A candidate's centre uniform over the zone positions whose footprint lies inside the region;
// false when none (or when rounding puts it at the zone's open end).
bool Place(const LayoutOptions& o, const ZoneOptions& zone, Rng& rng, Candidate& c,
           Eigen::Vector2d& p) {
  const Eigen::Vector2d half = c.footprint.HalfExtent();
  const double x_lo = std::max(zone.x_min, o.region.min_W.x() + half.x());
  const double x_hi = std::min(zone.x_max, o.region.max_W.x() - half.x());
  const double y_lo = o.region.min_W.y() + half.y();
  const double y_hi = o.region.max_W.y() - half.y();
  const double ux = Uniform01(rng);
  const double uy = Uniform01(rng);
  if (!(x_lo < x_hi) || !(y_lo <= y_hi)) return false;
  p = {x_lo + (x_hi - x_lo) * ux, y_lo + (y_hi - y_lo) * uy};
  if (p.x() >= zone.x_max) return false;
  MoveTo(c, p);
  return true;
}

// Fills one zone (see layout.hpp for the algorithm). Appends to `obstacles` and `grid`.
ZoneResult GenerateZone(const LayoutOptions& o, const ZoneOptions& zone, std::uint64_t zone_seed,
                        const std::vector<KeepOutZone>& keep_outs, const std::string& spacing_key,
                        detail::FootprintGrid& grid, ObstacleSet& obstacles) {
  Rng rng(zone_seed);
  const ObstacleMix& mix = o.MixOf(zone);
  const double band_lo = zone.spacing * (1.0 - o.tolerance);
  const double band_hi = zone.spacing * (1.0 + o.tolerance);
  const double hard_core = o.hard_core_ratio * zone.spacing;
  const std::size_t min_count = MinimumCount(o, zone);
  const bool by_count = o.density == DensityDefinition::kArea;
  const auto target_count = static_cast<std::size_t>(o.TargetCount(zone));

  detail::DelaunayIndex index;
  MeanTracker tracker(o.density == DensityDefinition::kFreeGap);
  ZoneResult result;
  long rejections = 0;
  for (;;) {
    ThrowIfCancelled("layout generation");  // SIGINT/SIGTERM (quadtune/common/cancel.hpp)
    if (rejections >= o.max_rejections) ThrowImpossibleZone(o, zone, spacing_key, tracker);
    ++result.darts;
    ++rejections;

    Candidate c = DrawShape(mix, rng);
    Eigen::Vector2d p;
    if (!Place(o, zone, rng, c, p)) continue;
    bool keep_out_hit = false;
    for (const KeepOutZone& k : keep_outs) {
      keep_out_hit = keep_out_hit || FootprintGap(c.footprint, k.center_W) < k.radius;
    }
    if (keep_out_hit) continue;
    if (index.NearestDistance(p) < hard_core) continue;
    if (grid.FindConflict(c.footprint) >= 0) continue;

    const std::size_t n = tracker.size();
    const double new_sum = tracker.Predict(c, p, index);
    bool done = false;
    if (by_count) {
      done = n + 1 >= target_count;
    } else if (n + 1 >= 2) {
      const double mean = new_sum / static_cast<double>(n + 1);
      if (mean < band_lo) continue;  // would overshoot the density
      done = mean <= band_hi && n + 1 >= min_count;
    }

    // Accept.
    index.Insert(p);
    tracker.Accept(c, new_sum);
    grid.Add(c.footprint);
    if (c.is_ring) {
      obstacles.rings.push_back(c.ring);
    } else {
      obstacles.cylinders.push_back(c.cylinder);
    }
    rejections = 0;
    if (done) break;
  }
  result.count = tracker.size();
  result.incremental_mean = tracker.mean();
  return result;
}

}  // namespace

LayoutStats MeasureLayout(const ObstacleSet& obstacles, const LayoutOptions& options) {
  LayoutStats stats;
  const std::vector<ZoneOptions> zones = options.EffectiveZones();
  std::vector<Eigen::Vector2d> all;
  all.reserve(obstacles.size());
  std::vector<std::vector<Eigen::Vector2d>> per_zone(zones.size());
  std::vector<std::vector<Footprint>> footprints(zones.size());
  stats.zones.resize(zones.size());
  auto zone_of = [&](double x) -> long {
    for (std::size_t i = 0; i < zones.size(); ++i) {
      const bool last = i + 1 == zones.size();
      if (x >= zones[i].x_min && (x < zones[i].x_max || (last && x == zones[i].x_max))) {
        return static_cast<long>(i);
      }
    }
    return -1;
  };
  auto add = [&](const Eigen::Vector2d& c, bool is_ring, const Footprint& f) {
    all.push_back(c);
    const long z = zone_of(c.x());
    if (z < 0) return;
    per_zone[static_cast<std::size_t>(z)].push_back(c);
    footprints[static_cast<std::size_t>(z)].push_back(f);
    ++(is_ring ? stats.zones[static_cast<std::size_t>(z)].rings
               : stats.zones[static_cast<std::size_t>(z)].cylinders);
  };
  for (const auto& c : obstacles.cylinders) add(c.center_W, false, FootprintOf(c));
  for (const auto& r : obstacles.rings) add(r.center_W.head<2>(), true, FootprintOf(r));
  stats.overall = MeasureSpacing(all);
  for (std::size_t i = 0; i < zones.size(); ++i) {
    stats.zones[i].x_min = zones[i].x_min;
    stats.zones[i].x_max = zones[i].x_max;
    stats.zones[i].target_spacing = zones[i].spacing;
    stats.zones[i].spacing = MeasureSpacing(per_zone[i]);
    stats.zones[i].gap = StatsOf(NearestFreeGaps(footprints[i]));
  }
  return stats;
}

Layout GenerateLayout(const LayoutOptions& options, std::uint64_t seed) {
  options.Validate();
  Layout layout;
  layout.options = options;
  layout.seed = seed;
  layout.obstacles.ground = options.ground;

  const std::vector<ZoneOptions> zones = options.EffectiveZones();
  double max_reach = 0.0;
  for (const ZoneOptions& z : zones) max_reach = std::max(max_reach, options.MixOf(z).MaxReach());
  detail::FootprintGrid grid(options.region, max_reach, options.min_gap);
  const std::vector<KeepOutZone> keep_outs = options.AllKeepOutZones();

  std::vector<ZoneResult> results;
  for (std::size_t i = 0; i < zones.size(); ++i) {
    const std::string key =
        options.zones.empty() ? "spacing" : "zones[" + std::to_string(i) + "].spacing";
    results.push_back(GenerateZone(options, zones[i], DeriveSeed(seed, {i}), keep_outs, key, grid,
                                   layout.obstacles));
  }

  layout.stats = MeasureLayout(layout.obstacles, options);
  for (std::size_t i = 0; i < zones.size(); ++i) {
    ZoneStats& z = layout.stats.zones[i];
    z.darts = results[i].darts;
    QT_DEMAND(z.spacing.count == results[i].count, "zone membership differs from generation");
    const double measured =
        options.density == DensityDefinition::kFreeGap ? z.gap.mean : z.spacing.mean;
    QT_DEMAND(std::abs(measured - results[i].incremental_mean) <= 1e-9 * z.target_spacing,
              "the incrementally tracked mean NN statistic differs from the measured one");
  }
  return layout;
}

}  // namespace quadtune::layout
