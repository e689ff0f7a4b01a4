#include "quadtune/planning/path_search.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <queue>

#include "quadtune/common/error.hpp"

namespace quadtune::planning {
namespace {

constexpr std::uint8_t kKnown = 1;     // occupancy looked up
constexpr std::uint8_t kOccupied = 2;  // inflated-occupied
constexpr std::uint8_t kClosed = 4;    // expanded

/// 3-D octile distance (cells) for a 26-connected lattice with costs 1, √2, √3.
double Octile(int dx, int dy, int dz) {
  // a[0] ≤ a[1] ≤ a[2]: the three magnitudes sorted by three compare-exchanges.
  std::array<int, 3> a{std::abs(dx), std::abs(dy), std::abs(dz)};
  if (a[0] > a[1]) std::swap(a[0], a[1]);
  if (a[1] > a[2]) std::swap(a[1], a[2]);
  if (a[0] > a[1]) std::swap(a[0], a[1]);
  constexpr double kS2 = 1.4142135623730951;
  constexpr double kS3 = 1.7320508075688772;
  return kS3 * a[0] + kS2 * (a[1] - a[0]) + (a[2] - a[1]);
}

struct OpenEntry {
  float f;
  float h;
  float g;
  std::int32_t idx;
};

/// Orders the priority queue so that top() is the smallest f, then smallest h, then index.
struct WorseThan {
  bool operator()(const OpenEntry& a, const OpenEntry& b) const {
    if (a.f != b.f) return a.f > b.f;
    if (a.h != b.h) return a.h > b.h;
    return a.idx > b.idx;
  }
};

struct Move {
  Eigen::Vector3i d;
  float cost;
  int n_sub;                        // intermediate cells that must be free (corner cutting)
  std::array<Eigen::Vector3i, 6> sub;
  std::uint32_t sub_mask = 0;       // the sub cells as bits of the moves' order (Moves())
};

const std::vector<Move>& Moves() {
  static const std::vector<Move> moves = [] {
    std::vector<Move> out;
    for (int dz = -1; dz <= 1; ++dz) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          if (dx == 0 && dy == 0 && dz == 0) continue;
          Move m;
          m.d = Eigen::Vector3i(dx, dy, dz);
          m.cost = static_cast<float>(std::sqrt(dx * dx + dy * dy + dz * dz));
          m.n_sub = 0;
          const int nonzero = (dx != 0) + (dy != 0) + (dz != 0);
          for (int mask = 1; mask < 7; ++mask) {
            Eigen::Vector3i s = Eigen::Vector3i::Zero();
            bool ok = true;
            int count = 0;
            for (int k = 0; k < 3; ++k) {
              if ((mask >> k) & 1) {
                if (m.d[k] == 0) ok = false;
                s[k] = m.d[k];
                ++count;
              }
            }
            if (ok && count < nonzero) m.sub[static_cast<std::size_t>(m.n_sub++)] = s;
          }
          out.push_back(m);
        }
      }
    }
    for (Move& m : out) {
      for (int s = 0; s < m.n_sub; ++s) {
        for (std::size_t k = 0; k < out.size(); ++k) {
          if (out[k].d == m.sub[static_cast<std::size_t>(s)]) m.sub_mask |= 1u << k;
        }
      }
    }
    return out;
  }();
  return moves;
}

double PolylineLength(const std::vector<Eigen::Vector3d>& p) {
  double len = 0.0;
  for (std::size_t i = 1; i < p.size(); ++i) len += (p[i] - p[i - 1]).norm();
  return len;
}

}  // namespace

// ---------------------------------------------------------------- options

const Fields<PathSearchOptions>& PathSearchFields() {
  using O = PathSearchOptions;
  static const Fields<O> fields =
      Fields<O>()
          .Integer("max_expansions", &O::max_expansions, Range::Closed(1, 1e8),
                   "A* expansions before giving up")
          .Number("search_margin", &O::search_margin, Range::Closed(0.0, 50.0),
                  "widening of the search box in x and y (m)")
          .Number("z_min", &O::z_min, Range::Any(),
                  "lowest cell-centre height searched (m); the start and goal heights are "
                  "always included")
          .Number("z_max", &O::z_max, Range::Any(),
                  "highest cell-centre height searched (m), > `z_min`")
          .Number("heuristic_weight", &O::heuristic_weight, Range::Closed(1.0, 10.0),
                  "f = g + w·h; w > 1 expands fewer cells, and the path is at most w times "
                  "longer than the shortest")
          .Number("start_escape_radius", &O::start_escape_radius, Range::Closed(0.0, 2.0),
                  "an occupied start may step to the nearest free cell within this radius (m)")
          .Integer("max_search_cells", &O::max_search_cells,
                   Range::Closed(1, static_cast<double>(1 << 27)), "largest search box (cells)");
  return fields;
}

namespace {
// The cross-field rule: z_max above z_min.
void CheckHeights(const PathSearchOptions& o, const std::string& file, const std::string& key) {
  CheckInRange(o.z_max, {o.z_min, std::numeric_limits<double>::infinity(), true, false}, file, key);
}
}  // namespace

void PathSearchOptions::Validate(const std::string& origin) const {
  PathSearchFields().Check(*this, origin);
  CheckHeights(*this, origin, "z_max");
}

PathSearchOptions PathSearchOptions::FromYaml(const YamlMap& map) {
  const PathSearchOptions o = PathSearchFields().Read(map);
  CheckHeights(o, map.file(), map.KeyPath("z_max"));
  return o;
}

// ---------------------------------------------------------------- free functions

LocalGoal ChooseLocalGoal(const LocalMap& map, const Eigen::Vector3d& start_W,
                          const Eigen::Vector3d& mission_goal_W, double h_pl) {
  CheckInRange(h_pl, Range::Positive(), "", "h_pl");
  if (!start_W.allFinite() || !mission_goal_W.allFinite()) {
    throw ConfigError("", "start/goal", "ChooseLocalGoal needs finite positions");
  }
  LocalGoal out;
  const Eigen::Vector3d delta = mission_goal_W - start_W;
  const double dist = delta.norm();
  const bool mission = dist <= h_pl;
  const double reach = mission ? dist : h_pl;
  const Eigen::Vector3d dir = dist > 0.0 ? Eigen::Vector3d(delta / dist) : Eigen::Vector3d::Zero();
  const Eigen::Vector3d candidate = mission ? mission_goal_W : Eigen::Vector3d(start_W + dir * h_pl);
  if (!map.IsOccupied(candidate)) {
    out.found = true;
    out.is_mission_goal = mission;
    out.p_W = candidate;
    return out;
  }
  const double step = 0.5 * map.resolution();
  for (double s = reach - step; s >= 0.0; s -= step) {
    const Eigen::Vector3d p = start_W + dir * s;
    if (!map.IsOccupied(p)) {
      out.found = true;
      out.p_W = p;
      return out;
    }
  }
  return out;
}

std::vector<Eigen::Vector3d> PrunePath(const LocalMap& map,
                                       const std::vector<Eigen::Vector3d>& points) {
  if (points.size() <= 2) return points;
  std::vector<Eigen::Vector3d> out{points.front()};
  std::size_t anchor = 0;
  const std::size_t last = points.size() - 1;
  while (anchor < last) {
    std::size_t next = anchor + 1;  // always progress, even if the first segment is blocked
    for (std::size_t j = anchor + 2; j <= last; ++j) {
      if (!map.SegmentFree(points[anchor], points[j])) break;
      next = j;
    }
    out.push_back(points[next]);
    anchor = next;
  }
  return out;
}

std::vector<Eigen::Vector3d> ResampleByArcLength(const std::vector<Eigen::Vector3d>& polyline,
                                                 int n_pieces) {
  QT_DEMAND(!polyline.empty() && n_pieces >= 1, "ResampleByArcLength: bad arguments");
  std::vector<double> s(polyline.size(), 0.0);
  for (std::size_t i = 1; i < polyline.size(); ++i) {
    s[i] = s[i - 1] + (polyline[i] - polyline[i - 1]).norm();
  }
  const double total = s.back();
  std::vector<Eigen::Vector3d> out;
  out.reserve(static_cast<std::size_t>(n_pieces) + 1);
  std::size_t seg = 0;
  for (int k = 0; k <= n_pieces; ++k) {
    if (k == n_pieces) {
      out.push_back(polyline.back());
      break;
    }
    const double target = total * k / n_pieces;
    while (seg + 2 < polyline.size() && s[seg + 1] < target) ++seg;
    if (polyline.size() == 1) {
      out.push_back(polyline.front());
      continue;
    }
    const double len = s[seg + 1] - s[seg];
    const double t = len > 0.0 ? std::clamp((target - s[seg]) / len, 0.0, 1.0) : 0.0;
    out.push_back(polyline[seg] + t * (polyline[seg + 1] - polyline[seg]));
  }
  return out;
}

// ---------------------------------------------------------------- searcher

PathSearcher::PathSearcher(const PathSearchOptions& options) : options_(options) {
  options_.Validate();
}

PathSearchResult PathSearcher::Plan(const LocalMap& map, const Eigen::Vector3d& start_W,
                                    const Eigen::Vector3d& mission_goal_W, double h_pl) {
  const LocalGoal local = ChooseLocalGoal(map, start_W, mission_goal_W, h_pl);
  if (!local.found) {
    PathSearchResult r;
    r.status = PathSearchStatus::kNoFreeLocalGoal;
    r.start_W = start_W;
    r.goal_W = mission_goal_W;
    r.message = "no free local goal on the line from the drone towards the mission goal";
    return r;
  }
  PathSearchResult r = Search(map, start_W, local.p_W);
  r.goal_is_mission_goal = local.is_mission_goal;
  return r;
}

/// The search box [lo, hi] (inclusive, global cells) and the local index of its cells.
struct PathSearcher::SearchBox {
  CellIndex lo;
  CellIndex hi;
  Eigen::Vector3i dims;
  int nx = 0;
  int nxy = 0;

  [[nodiscard]] int Index(const CellIndex& g) const {
    const CellIndex l = g - lo;
    return l.x() + nx * l.y() + nxy * l.z();
  }
  [[nodiscard]] CellIndex Cell(int idx) const {
    return CellIndex(lo.x() + idx % nx, lo.y() + (idx / nx) % dims.y(), lo.z() + idx / nxy);
  }
  [[nodiscard]] bool Inside(const CellIndex& g) const {
    return (g.array() >= lo.array()).all() && (g.array() <= hi.array()).all();
  }
};

PathSearcher::SearchBox PathSearcher::BoxAround(const LocalMap& map, const CellIndex& start_cell,
                                                const CellIndex& goal_cell) const {
  const int margin = static_cast<int>(std::ceil(options_.search_margin / map.resolution()));
  SearchBox box;
  box.lo = start_cell.cwiseMin(goal_cell);
  box.hi = start_cell.cwiseMax(goal_cell);
  box.lo.head<2>().array() -= margin;
  box.hi.head<2>().array() += margin;
  const int z_lo = map.CellOf(Eigen::Vector3d(0, 0, options_.z_min)).z();
  const int z_hi = map.CellOf(Eigen::Vector3d(0, 0, options_.z_max)).z();
  box.lo.z() = std::min(box.lo.z(), z_lo);
  box.hi.z() = std::max(box.hi.z(), std::max(z_hi, z_lo));
  box.dims = box.hi - box.lo + Eigen::Vector3i::Ones();
  box.nx = box.dims.x();
  box.nxy = box.dims.x() * box.dims.y();
  return box;
}

void PathSearcher::ResetCells(std::size_t n_cells) {
  if (cell_stamp_.size() < n_cells) {
    cell_stamp_.assign(n_cells, 0);
    g_.resize(n_cells);
    parent_.resize(n_cells);
    flags_.resize(n_cells);
  }
  if (++stamp_ == 0) {  // wrapped: invalidate everything
    std::fill(cell_stamp_.begin(), cell_stamp_.end(), 0);
    stamp_ = 1;
  }
}

bool PathSearcher::Occupied(const LocalMap& map, const CellIndex& g, int idx) {
  const auto i = static_cast<std::size_t>(idx);
  if (cell_stamp_[i] != stamp_) {  // first touch in this search
    cell_stamp_[i] = stamp_;
    flags_[i] = 0;
    g_[i] = std::numeric_limits<float>::infinity();
    parent_[i] = -1;
  }
  std::uint8_t& f = flags_[i];
  if ((f & kKnown) == 0) f |= kKnown | (map.IsOccupiedCell(g) ? kOccupied : 0);
  return (f & kOccupied) != 0;
}

bool PathSearcher::FreeStartCell(const LocalMap& map, const SearchBox& box,
                                 const Eigen::Vector3d& start_W, const CellIndex& start_cell,
                                 CellIndex* first) {
  *first = start_cell;
  if (!Occupied(map, start_cell, box.Index(start_cell))) return true;
  const int r = static_cast<int>(std::ceil(options_.start_escape_radius / map.resolution()));
  double best = std::numeric_limits<double>::infinity();
  bool found = false;
  for (int dz = -r; dz <= r; ++dz) {
    for (int dy = -r; dy <= r; ++dy) {
      for (int dx = -r; dx <= r; ++dx) {
        const CellIndex c = start_cell + CellIndex(dx, dy, dz);
        if (!box.Inside(c)) continue;
        const double d = (map.CellCenter(c) - start_W).norm();
        if (d > options_.start_escape_radius || d >= best) continue;
        if (Occupied(map, c, box.Index(c))) continue;
        best = d;
        *first = c;
        found = true;
      }
    }
  }
  return found;
}

PathSearchStatus PathSearcher::AStar(const LocalMap& map, const SearchBox& box,
                                     const CellIndex& first, const CellIndex& goal_cell,
                                     int* expansions) {
  const float w = static_cast<float>(options_.heuristic_weight);
  auto heuristic = [&](const CellIndex& g) {
    const CellIndex d = goal_cell - g;
    return static_cast<float>(Octile(d.x(), d.y(), d.z()));
  };
  std::priority_queue<OpenEntry, std::vector<OpenEntry>, WorseThan> open;
  const int first_idx = box.Index(first);
  const int goal_idx = box.Index(goal_cell);
  g_[static_cast<std::size_t>(first_idx)] = 0.0f;
  {
    const float h = heuristic(first);
    open.push({w * h, h, 0.0f, first_idx});
  }
  const std::vector<Move>& moves = Moves();
  // Per move, the offset of its target in the box's cell index: a neighbour's index is then
  // one addition (its coordinates are only range-checked).
  QT_DEMAND(moves.size() == 26, "26-connected moves");
  std::array<int, 26> move_offset{};
  for (std::size_t k = 0; k < moves.size(); ++k) {
    const Eigen::Vector3i& d = moves[k].d;
    move_offset[k] = d.x() + box.nx * d.y() + box.nxy * d.z();
  }
  *expansions = 0;
  while (!open.empty()) {
    const OpenEntry top = open.top();
    open.pop();
    const auto ti = static_cast<std::size_t>(top.idx);
    if ((flags_[ti] & kClosed) != 0 || top.g > g_[ti]) continue;  // stale entry
    if (top.idx == goal_idx) return PathSearchStatus::kSuccess;
    if (*expansions >= options_.max_expansions) return PathSearchStatus::kExpansionLimit;
    flags_[ti] |= kClosed;
    ++*expansions;
    const CellIndex c = box.Cell(top.idx);
    // The occupancy of the 26 neighbours inside the box, one bit per move. A move's corner
    // cells are neighbours too, and inside the box whenever its target is.
    std::uint32_t outside = 0;
    std::uint32_t occupied_mask = 0;
    for (std::size_t k = 0; k < moves.size(); ++k) {
      const CellIndex nb = c + moves[k].d;
      if (!box.Inside(nb)) {
        outside |= 1u << k;
      } else if (Occupied(map, nb, top.idx + move_offset[k])) {
        occupied_mask |= 1u << k;
      }
    }
    for (std::size_t k = 0; k < moves.size(); ++k) {
      if (((outside | occupied_mask) >> k) & 1u) continue;
      const Move& m = moves[k];
      const int ni = top.idx + move_offset[k];
      const auto nu = static_cast<std::size_t>(ni);
      if ((flags_[nu] & kClosed) != 0) continue;
      if ((occupied_mask & m.sub_mask) != 0) continue;  // cuts an occupied corner
      const CellIndex nb = c + m.d;
      const float g_new = top.g + m.cost;
      if (g_new < g_[nu]) {
        g_[nu] = g_new;
        parent_[nu] = top.idx;
        const float h = heuristic(nb);
        open.push({g_new + w * h, h, g_new, ni});
      }
    }
  }
  return PathSearchStatus::kNoPath;
}

void PathSearcher::TracePath(const LocalMap& map, const SearchBox& box, int goal_idx,
                             PathSearchResult& result) const {
  // Cell path, start → goal.
  for (int idx = goal_idx; idx >= 0; idx = parent_[static_cast<std::size_t>(idx)]) {
    result.path.push_back(map.CellCenter(box.Cell(idx)));
  }
  std::reverse(result.path.begin(), result.path.end());
  std::vector<Eigen::Vector3d> points;
  points.reserve(result.path.size() + 2);
  points.push_back(result.start_W);
  points.insert(points.end(), result.path.begin(), result.path.end());
  points.push_back(result.goal_W);
  result.waypoints = PrunePath(map, points);
  // Drop points that coincide with a neighbour (start/goal within their cell centres).
  result.waypoints.erase(std::unique(result.waypoints.begin(), result.waypoints.end(),
                                     [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
                                       return (a - b).squaredNorm() < 1e-18;
                                     }),
                         result.waypoints.end());
  result.length = PolylineLength(result.waypoints);
}

PathSearchResult PathSearcher::Search(const LocalMap& map, const Eigen::Vector3d& start_W,
                                      const Eigen::Vector3d& goal_W) {
  if (!start_W.allFinite() || !goal_W.allFinite()) {
    throw ConfigError("", "start/goal", "PathSearcher::Search needs finite positions");
  }
  PathSearchResult result;
  result.start_W = start_W;
  result.goal_W = goal_W;
  auto fail = [&](PathSearchStatus status, std::string message) {
    result.status = status;
    result.message = std::move(message);
    result.path.clear();
    result.waypoints.clear();
    return result;
  };

  const CellIndex start_cell = map.CellOf(start_W);
  const CellIndex goal_cell = map.CellOf(goal_W);
  if (map.IsOccupiedCell(goal_cell)) {
    return fail(PathSearchStatus::kGoalOccupied, "the goal cell is occupied (inflated map)");
  }
  const SearchBox box = BoxAround(map, start_cell, goal_cell);
  const double n_cells_d = static_cast<double>(box.dims.x()) * box.dims.y() * box.dims.z();
  if (n_cells_d > options_.max_search_cells) {
    return fail(
        PathSearchStatus::kSearchBoxTooLarge,
        "the search box holds " + std::to_string(static_cast<long long>(n_cells_d)) +
            " cells, more than max_search_cells = " + std::to_string(options_.max_search_cells));
  }
  ResetCells(static_cast<std::size_t>(n_cells_d));
  CellIndex first;  // the start cell, or the nearest free cell within start_escape_radius
  if (!FreeStartCell(map, box, start_W, start_cell, &first)) {
    return fail(PathSearchStatus::kStartOccupied,
                "the start cell and every cell within start_escape_radius are occupied");
  }
  int expansions = 0;
  const PathSearchStatus status = AStar(map, box, first, goal_cell, &expansions);
  result.expansions = expansions;
  if (status == PathSearchStatus::kExpansionLimit) {
    return fail(status, "A* reached max_expansions = " + std::to_string(options_.max_expansions) +
                            " before the goal");
  }
  if (status == PathSearchStatus::kNoPath) {
    return fail(status,
                "no path: start or goal is enclosed, or the way around leaves the search "
                "box (search_margin); " +
                    std::to_string(expansions) + " cells expanded");
  }
  TracePath(map, box, box.Index(goal_cell), result);
  result.status = PathSearchStatus::kSuccess;
  result.message = "path found: " + std::to_string(result.path.size()) + " cells, " +
                   std::to_string(result.waypoints.size()) + " waypoints, " +
                   std::to_string(expansions) + " expansions";
  return result;
}

}  // namespace quadtune::planning
