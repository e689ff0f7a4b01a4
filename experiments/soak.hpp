#pragma once
/// The soak benchmark's verdict on resident memory (`quadtune bench --soak N`).
///
/// Pure function of the RSS samples; no I/O. Thread safety: none needed (values only).

#include <utility>
#include <vector>

namespace quadtune::cli {

/// Whether the resident set stays flat after warm-up. Allocators hold and return whole segments,
/// so single samples jump by a segment (about 2 MiB with mimalloc) either way. Growth is judged on
/// the medians of ten consecutive windows of the samples after warm-up (the last against the
/// first) and on the least-squares trend over those samples. Flat: both within 5 %.
struct SoakVerdict {
  double low = 0.0, high = 0.0;                // smallest and largest sample after warm-up (MiB)
  double first_median = 0.0, last_median = 0.0;  // window medians (MiB)
  double max_median = 0.0;                       // largest window median (MiB)
  double growth = 0.0;                           // (last_median − first_median) / first_median
  double trend = 0.0;                           // fitted change over the samples / mean
  bool flat = true;
};

/// The verdict on `samples` ((flights done, RSS MiB), ascending in flights), judging only the
/// samples taken at `warmup` flights or later. With no such sample: flat, all figures 0.
[[nodiscard]] SoakVerdict JudgeSoak(const std::vector<std::pair<int, double>>& samples,
                                    int warmup);

}  // namespace quadtune::cli
