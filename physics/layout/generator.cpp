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

// Fills one zone (see layout.hpp for the algorithm). Appends to `obstacles` and `grid`.
ZoneResult GenerateZone(const LayoutOptions& o, const ZoneOptions& zone, std::uint64_t zone_seed,
                        const std::vector<KeepOutZone>& keep_outs, const std::string& spacing_key,
                        detail::FootprintGrid& grid, ObstacleSet& obstacles) {
  Rng rng(zone_seed);
  const ObstacleMix& mix = o.MixOf(zone);
  const double target = zone.spacing;
  const double band_lo = target * (1.0 - o.tolerance);
  const double band_hi = target * (1.0 + o.tolerance);
  const double hard_core = o.hard_core_ratio * target;
  // A Poisson forest of intensity λ has mean NN distance 1 / (2 sqrt(λ)); hard cores and the
  // region's border only raise it. Half of that count is a safe lower bound on where to stop.
  const double zone_area = o.ZoneArea(zone);
  const std::size_t min_count = std::max<std::size_t>(
      2, static_cast<std::size_t>(std::floor(0.5 * zone_area / (4.0 * target * target))));
  const bool by_count = o.density == DensityDefinition::kArea;
  const auto target_count = static_cast<std::size_t>(o.TargetCount(zone));

  detail::DelaunayIndex index;
  std::vector<double> nn;  // NN distance of every zone obstacle so far (m)
  double nn_sum = 0.0;
  std::vector<detail::DelaunayIndex::Neighbour> neighbours;
  ZoneResult result;
  long rejections = 0;
  for (;;) {
    ThrowIfCancelled("layout generation");  // SIGINT/SIGTERM (quadtune/common/cancel.hpp)
    if (rejections >= o.max_rejections && by_count) {
      throw ConfigError(
          "", spacing_key,
          "cannot place the " + std::to_string(target_count) + " obstacles that spacing " +
              Num(target) + " m asks for in the zone x in [" + Num(zone.x_min) + ", " +
              Num(zone.x_max) + ") (area / (4 spacing²) of " + Num(zone_area) +
              " m²): " + std::to_string(nn.size()) + " placed, then the last " +
              std::to_string(o.max_rejections) +
              " candidates were all rejected (overlap within min_gap, keep-out zones, "
              "hard_core_ratio); use a larger spacing, smaller obstacles, a smaller min_gap or "
              "hard_core_ratio, or fewer/smaller keep-out zones");
    }
    if (rejections >= o.max_rejections) {
      const std::size_t n = nn.size();
      throw ConfigError(
          "", spacing_key,
          "cannot reach the target spacing of " + Num(target) + " m: with " + std::to_string(n) +
              " obstacles in the zone x in [" + Num(zone.x_min) + ", " + Num(zone.x_max) +
              ") the mean nearest-neighbour spacing is " +
              (n >= 2 ? Num(nn_sum / static_cast<double>(n)) + " m" : std::string("undefined")) +
              " and the last " + std::to_string(o.max_rejections) +
              " candidates were all rejected (overlap within min_gap, keep-out zones, "
              "hard_core_ratio, or overshooting the target); use a larger spacing, smaller "
              "obstacles, a smaller min_gap or hard_core_ratio, or fewer/smaller keep-out zones");
    }
    ++result.darts;
    ++rejections;

    Candidate c = DrawShape(mix, rng);
    // Centre uniform over the zone positions whose footprint lies inside the region.
    const Eigen::Vector2d half = c.footprint.HalfExtent();
    const double x_lo = std::max(zone.x_min, o.region.min_W.x() + half.x());
    const double x_hi = std::min(zone.x_max, o.region.max_W.x() - half.x());
    const double y_lo = o.region.min_W.y() + half.y();
    const double y_hi = o.region.max_W.y() - half.y();
    const double ux = Uniform01(rng);
    const double uy = Uniform01(rng);
    if (!(x_lo < x_hi) || !(y_lo <= y_hi)) continue;
    const Eigen::Vector2d p(x_lo + (x_hi - x_lo) * ux, y_lo + (y_hi - y_lo) * uy);
    if (p.x() >= zone.x_max) continue;  // rounding at the zone's open end
    MoveTo(c, p);

    bool keep_out_hit = false;
    for (const KeepOutZone& k : keep_outs) {
      keep_out_hit = keep_out_hit || FootprintGap(c.footprint, k.center_W) < k.radius;
    }
    if (keep_out_hit) continue;
    if (index.NearestDistance(p) < hard_core) continue;
    if (grid.FindConflict(c.footprint) >= 0) continue;

    // Predict the zone's mean NN spacing with p: only p's Delaunay neighbours can change.
    const std::size_t n = nn.size();
    index.PotentialNeighbours(p, neighbours);
    double p_nn = std::numeric_limits<double>::infinity();
    double new_sum = nn_sum;
    for (const auto& [id, d] : neighbours) {
      p_nn = std::min(p_nn, d);
      if (n >= 2 && d < nn[id]) new_sum -= nn[id] - d;
    }
    new_sum = n == 0 ? 0.0 : (n == 1 ? 2.0 * p_nn : new_sum + p_nn);
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
    for (const auto& [id, d] : neighbours) nn[id] = std::min(nn[id], d);
    nn.push_back(p_nn);
    nn_sum = new_sum;
    grid.Add(c.footprint);
    if (c.is_ring) {
      obstacles.rings.push_back(c.ring);
    } else {
      obstacles.cylinders.push_back(c.cylinder);
    }
    rejections = 0;
    if (done) break;
  }
  result.count = nn.size();
  result.incremental_mean = nn_sum / static_cast<double>(nn.size());
  return result;
}

}  // namespace

LayoutStats MeasureLayout(const ObstacleSet& obstacles, const LayoutOptions& options) {
  LayoutStats stats;
  const std::vector<ZoneOptions> zones = options.EffectiveZones();
  std::vector<Eigen::Vector2d> all;
  all.reserve(obstacles.size());
  std::vector<std::vector<Eigen::Vector2d>> per_zone(zones.size());
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
  auto add = [&](const Eigen::Vector2d& c, bool is_ring) {
    all.push_back(c);
    const long z = zone_of(c.x());
    if (z < 0) return;
    per_zone[static_cast<std::size_t>(z)].push_back(c);
    ++(is_ring ? stats.zones[static_cast<std::size_t>(z)].rings
               : stats.zones[static_cast<std::size_t>(z)].cylinders);
  };
  for (const auto& c : obstacles.cylinders) add(c.center_W, false);
  for (const auto& r : obstacles.rings) add(r.center_W.head<2>(), true);
  stats.overall = MeasureSpacing(all);
  for (std::size_t i = 0; i < zones.size(); ++i) {
    stats.zones[i].x_min = zones[i].x_min;
    stats.zones[i].x_max = zones[i].x_max;
    stats.zones[i].target_spacing = zones[i].spacing;
    stats.zones[i].spacing = MeasureSpacing(per_zone[i]);
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
    QT_DEMAND(std::abs(z.spacing.mean - results[i].incremental_mean) <= 1e-9 * z.target_spacing,
              "the incrementally tracked mean NN spacing differs from the measured one");
  }
  return layout;
}

}  // namespace quadtune::layout
