// Google Benchmark: time to generate obstacle layouts over a 40 x 10 m corridor at the paper's
// four average spacings (3.0, 2.1, 1.3, 0.9 m), with the obstacle mixtures of
// assets/layouts/forest_*.yaml, and to measure spacing.
#include <benchmark/benchmark.h>

#include <string>

#include "quadtune/common/yaml.hpp"
#include "quadtune/layout/layout.hpp"

namespace {

using quadtune::layout::GenerateLayout;
using quadtune::layout::LayoutOptions;

LayoutOptions Corridor40x10(const std::string& asset) {
  LayoutOptions o =
      LayoutOptions::LoadFile(std::string(QUADTUNE_SOURCE_DIR) + "/assets/layouts/" + asset);
  o.region.min_W = {0.0, -5.0};
  o.region.max_W = {40.0, 5.0};
  o.mission.goal_W = {40.0, 0.0, 1.2};
  return o;
}

void BM_Generate(benchmark::State& state, const std::string& asset) {
  const LayoutOptions o = Corridor40x10(asset);
  std::uint64_t seed = 0;
  double mean = 0.0;
  double count = 0.0;
  double darts = 0.0;
  for (auto _ : state) {
    const auto layout = GenerateLayout(o, seed++);
    benchmark::DoNotOptimize(layout.obstacles.cylinders.data());
    mean += layout.stats.zones[0].spacing.mean;
    count += static_cast<double>(layout.obstacles.size());
    darts += static_cast<double>(layout.stats.zones[0].darts);
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["spacing_m"] = mean / n;
  state.counters["obstacles"] = count / n;
  state.counters["darts"] = darts / n;
}

void BM_MeasureSpacing(benchmark::State& state) {
  const auto layout = GenerateLayout(Corridor40x10("forest_thin_0p9.yaml"), 1);
  std::vector<Eigen::Vector2d> points;
  for (const auto& c : layout.obstacles.cylinders) points.push_back(c.center_W);
  for (const auto& r : layout.obstacles.rings) points.push_back(r.center_W.head<2>());
  for (auto _ : state) {
    benchmark::DoNotOptimize(quadtune::layout::MeasureSpacing(points).mean);
  }
  state.counters["points"] = static_cast<double>(points.size());
}

}  // namespace

BENCHMARK_CAPTURE(BM_Generate, spacing_0p9_40x10, std::string("forest_thin_0p9.yaml"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Generate, spacing_1p3_40x10, std::string("forest_thin_1p3.yaml"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Generate, spacing_2p1_40x10, std::string("forest_thin_2p1.yaml"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_Generate, spacing_3p0_40x10, std::string("forest_thin_3p0.yaml"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MeasureSpacing)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
