#include "soak.hpp"

#include <algorithm>
#include <cstddef>
#include <limits>

namespace quadtune::cli {

SoakVerdict JudgeSoak(const std::vector<std::pair<int, double>>& samples, int warmup) {
  std::vector<std::pair<int, double>> after;
  for (const auto& s : samples) {
    if (s.first >= warmup) after.push_back(s);
  }
  SoakVerdict v;
  if (after.empty()) return v;
  v.low = std::numeric_limits<double>::infinity();
  double sx = 0.0, sy = 0.0;
  for (const auto& [d, rss] : after) {
    v.low = std::min(v.low, rss);
    v.high = std::max(v.high, rss);
    sx += d;
    sy += rss;
  }
  const double n = static_cast<double>(after.size());
  const double mx = sx / n, my = sy / n;
  double sxx = 0.0, sxy = 0.0;
  for (const auto& [d, rss] : after) {
    sxx += (d - mx) * (d - mx);
    sxy += (d - mx) * (rss - my);
  }
  const double span = static_cast<double>(after.back().first - after.front().first);
  v.trend = sxx > 0.0 ? sxy / sxx * span / my : 0.0;
  const std::size_t windows = std::min<std::size_t>(10, after.size());
  for (std::size_t w = 0; w < windows; ++w) {
    std::vector<double> rss;
    for (std::size_t k = w * after.size() / windows; k < (w + 1) * after.size() / windows; ++k) {
      rss.push_back(after[k].second);
    }
    std::nth_element(rss.begin(), rss.begin() + static_cast<std::ptrdiff_t>(rss.size() / 2),
                     rss.end());
    const double median = rss[rss.size() / 2];
    if (w == 0) v.first_median = median;
    v.last_median = median;
    v.max_median = std::max(v.max_median, median);
  }
  v.growth = (v.last_median - v.first_median) / v.first_median;
  v.flat = v.growth <= 0.05 && v.trend <= 0.05;
  return v;
}

}  // namespace quadtune::cli
