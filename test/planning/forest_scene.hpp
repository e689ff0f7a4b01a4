#pragma once
/// \file
/// Representative planning queries for tests and benchmarks: a cylinder forest (~1.3 m spacing)
/// between the start and a local goal 7.5 m away, with a collision-free initial path from a small
/// 2-D grid A* (a stand-in for the front-end path search).

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <memory>
#include <queue>
#include <vector>

#include "analytic_fields.hpp"
#include "quadtune/planning/ipopt/trajectory_optimizer.hpp"

namespace quadtune::planning::testing {

/// 8-connected A* on a grid (resolution `res`, m) at height z over [x0,x1]×[y0,y1]; a cell is free
/// when field distance >= `inflate`. Returns the path from start to goal (empty if none).
inline std::vector<Eigen::Vector3d> GridAStar(const DistanceField& field,
                                              const Eigen::Vector3d& start,
                                              const Eigen::Vector3d& goal, double x0, double x1,
                                              double y0, double y1, double res, double inflate) {
  const int nx = static_cast<int>(std::ceil((x1 - x0) / res)) + 1;
  const int ny = static_cast<int>(std::ceil((y1 - y0) / res)) + 1;
  const double z = start.z();
  auto idx = [&](int i, int j) { return j * nx + i; };
  std::vector<char> free(static_cast<std::size_t>(nx * ny));
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      free[static_cast<std::size_t>(idx(i, j))] =
          field.Evaluate(Eigen::Vector3d(x0 + i * res, y0 + j * res, z), nullptr) >= inflate;
  auto cell = [&](const Eigen::Vector3d& p) {
    return std::pair<int, int>{
        std::clamp(static_cast<int>(std::lround((p.x() - x0) / res)), 0, nx - 1),
        std::clamp(static_cast<int>(std::lround((p.y() - y0) / res)), 0, ny - 1)};
  };
  const auto [si, sj] = cell(start);
  const auto [gi, gj] = cell(goal);
  free[static_cast<std::size_t>(idx(si, sj))] = 1;
  free[static_cast<std::size_t>(idx(gi, gj))] = 1;
  std::vector<double> g(free.size(), 1e300);
  std::vector<int> parent(free.size(), -1);
  using Item = std::pair<double, int>;
  std::priority_queue<Item, std::vector<Item>, std::greater<>> open;
  auto h = [&](int i, int j) { return std::hypot(i - gi, j - gj) * res; };
  g[static_cast<std::size_t>(idx(si, sj))] = 0.0;
  open.push({h(si, sj), idx(si, sj)});
  while (!open.empty()) {
    const auto [f, k] = open.top();
    open.pop();
    const int i = k % nx;
    const int j = k / nx;
    if (i == gi && j == gj) break;
    if (f > g[static_cast<std::size_t>(k)] + h(i, j) + 1e-12) continue;
    for (int dj = -1; dj <= 1; ++dj)
      for (int di = -1; di <= 1; ++di) {
        if (di == 0 && dj == 0) continue;
        const int a = i + di;
        const int b = j + dj;
        if (a < 0 || b < 0 || a >= nx || b >= ny || !free[static_cast<std::size_t>(idx(a, b))])
          continue;
        const double ng = g[static_cast<std::size_t>(k)] + std::hypot(di, dj) * res;
        if (ng < g[static_cast<std::size_t>(idx(a, b))]) {
          g[static_cast<std::size_t>(idx(a, b))] = ng;
          parent[static_cast<std::size_t>(idx(a, b))] = k;
          open.push({ng + h(a, b), idx(a, b)});
        }
      }
  }
  std::vector<Eigen::Vector3d> path;
  int k = idx(gi, gj);
  if (parent[static_cast<std::size_t>(k)] < 0 && k != idx(si, sj)) return path;
  for (; k >= 0; k = parent[static_cast<std::size_t>(k)])
    path.emplace_back(x0 + (k % nx) * res, y0 + (k / nx) * res, z);
  std::reverse(path.begin(), path.end());
  path.front() = start;
  path.back() = goal;
  return path;
}

/// A forest query: field + request (start at rest at (0, 0, 1), goal (7.5, 0, 1)).
struct ForestQuery {
  std::shared_ptr<CylinderField> field;
  PlanRequest request;
  std::vector<physics::CylinderObstacle> cylinders;  ///< the obstacles of `field`
};

/// The query's cylinders as an Esdf (0.1 m voxels) over the region the plans use.
inline Esdf ForestEsdf(const ForestQuery& q) {
  return VoxelisedCylinders(q.cylinders, -1.5, 9.0, -5.0, 5.0, 0.0, 2.0);
}

/// Query number `seed` of the representative set (cylinder spacing `spacing`, m).
inline ForestQuery MakeForestQuery(unsigned seed, double spacing = 1.3) {
  ForestQuery q;
  q.request.p0_W = Eigen::Vector3d(0.0, 0.0, 1.0);
  q.request.goal_W = Eigen::Vector3d(7.5, 0.0, 1.0);
  // A moving start for odd seeds (a re-plan in flight).
  if (seed % 2 == 1) {
    q.request.v0_W = Eigen::Vector3d(1.0, 0.2, 0.0);
    q.request.a0_W = Eigen::Vector3d(0.3, -0.2, 0.0);
  }
  q.cylinders = MakeForest(spacing, 1.0, 6.5, -4.0, 4.0,
                           {Eigen::Vector2d(0, 0), Eigen::Vector2d(7.5, 0)}, 0.9, seed);
  q.field = std::make_shared<CylinderField>(q.cylinders);
  q.request.initial_path_W =
      GridAStar(*q.field, q.request.p0_W, q.request.goal_W, -1.0, 9.0, -6.0, 6.0, 0.1, 0.3);
  return q;
}

}  // namespace quadtune::planning::testing
