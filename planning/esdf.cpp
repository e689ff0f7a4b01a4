#include "quadtune/planning/esdf.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "quadtune/common/error.hpp"

namespace quadtune::planning {
namespace {

constexpr std::int32_t kInfSq = std::numeric_limits<std::int32_t>::max() / 4;
constexpr double kQuantumSteps = 16000.0;
constexpr std::size_t kMaxCells = std::size_t{1} << 26;
// The windowed transform's 16-bit "no site within the truncation": above every kept value, and
// kInf16 + cap stays below 2^15 for cap ≤ kMaxWindowedCap.
constexpr std::int16_t kInf16 = 16384;
constexpr std::int32_t kMaxWindowedCap = 8191;
// Values of a row the windowed transform carries through the window at once.
constexpr std::size_t kChunk = 32;
// The truncation (cells) of the first try at the inside transform (EsdfBuilder::Compute).
constexpr int kInsideProbeCells = 6;

/// 1-D squared distance transform of f (kInfSq = no site) by the lower envelope of parabolas
/// (Felzenszwalb & Huttenlocher). Writes d; values above `cap` become kInfSq. Scratch: v, fv
/// (n entries), z (n + 1 entries). Intersections are exact enough in float: they are rationals
/// with denominators ≤ 2n, so rounding never moves one across an integer.
void LowerEnvelope(const std::int32_t* f, int n, std::int32_t* d, int* v, float* fv, float* z,
                   std::int32_t cap) {
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (f[q] >= kInfSq) continue;
    const float fq = static_cast<float>(f[q]) + static_cast<float>(q * q);
    // Pop the parabolas hidden by q: intersection s = (fq − fv) / (2 (q − v)) ≤ z[k], tested
    // without the division (the denominator is positive).
    float num = 0.0f;
    float den = 1.0f;
    while (k >= 0) {
      num = fq - fv[k];
      den = static_cast<float>(2 * (q - v[k]));
      if (num > z[k] * den) break;
      --k;
    }
    ++k;
    v[k] = q;
    fv[k] = fq;
    z[k] = k == 0 ? -std::numeric_limits<float>::infinity() : num / den;
  }
  if (k < 0) {
    std::fill(d, d + n, kInfSq);
    return;
  }
  z[k + 1] = std::numeric_limits<float>::infinity();
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[j + 1] < static_cast<float>(q)) ++j;
    const int dq = q - v[j];
    const std::int32_t val = dq * dq + f[v[j]];
    d[q] = val > cap ? kInfSq : val;
  }
}

/// The pass along x of both transforms: per row of nx cells, the squared distance (cells²) to
/// the nearest cell of the row whose occupancy equals `target`, or `inf` beyond t_cells (two
/// sweeps; the first keeps at most t_cells + 1, so T may be 16-bit).
template <typename T>
void RowPass(const std::uint8_t* occupancy, std::size_t nx, std::size_t rows, bool target,
             int t_cells, T inf, T* g) {
  for (std::size_t row = 0; row < rows; ++row) {
    const std::uint8_t* o = occupancy + row * nx;
    T* r = g + row * nx;
    int last = -(1 << 20);
    for (std::size_t x = 0; x < nx; ++x) {
      if ((o[x] != 0) == target) last = static_cast<int>(x);
      r[x] = static_cast<T>(std::min(static_cast<int>(x) - last, t_cells + 1));
    }
    last = 1 << 21;
    for (std::size_t x = nx; x-- > 0;) {
      if ((o[x] != 0) == target) last = static_cast<int>(x);
      const int dx = std::min(static_cast<int>(r[x]), last - static_cast<int>(x));
      r[x] = dx > t_cells ? inf : static_cast<T>(dx * dx);
    }
  }
}

/// One pass of the windowed transform along y or z: rows of nx contiguous values, read from
/// `in` (rows nx apart) and written to `dst` (rows `stride` apart); out_row(q) = min over
/// |k| ≤ t_cells of in_row(q + k) + k², then values above cap become kInf16. kChunk values of a
/// row at a time are held over the whole window; the loops over them vectorise (16-bit min and
/// add), with an AVX2 clone picked at load time where the processor has it. A chunk of a row
/// that holds only kInf16 cannot lower a minimum (kInf16 + k² ≥ kInf16 ≥ every running minimum),
/// so such chunks are skipped: `live` (rows · ⌊nx / kChunk⌋ entries) records the others.
// Not under ThreadSanitizer: the clone's resolver runs while the program is being loaded, before
// the TSan runtime is up, and GCC instruments it (the program then crashes before main).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__SANITIZE_THREAD__)
__attribute__((target_clones("avx2", "default")))
#endif
void WindowedPass(const std::int16_t* in, std::int16_t* dst, std::size_t nx, int rows,
                  std::size_t stride, int t_cells, std::int16_t cap, std::uint8_t* live) {
  const std::size_t chunks = nx / kChunk;
  for (int r = 0; r < rows; ++r) {
    for (std::size_t ci = 0; ci < chunks; ++ci) {
      const std::int16_t* src = in + nx * static_cast<std::size_t>(r) + ci * kChunk;
      std::int16_t low = kInf16;
      for (std::size_t c = 0; c < kChunk; ++c) low = std::min(low, src[c]);
      live[static_cast<std::size_t>(r) * chunks + ci] = low < kInf16 ? 1 : 0;
    }
  }
  for (int q = 0; q < rows; ++q) {
    std::int16_t* o = dst + stride * static_cast<std::size_t>(q);
    const int k_lo = std::max(-t_cells, -q);
    const int k_hi = std::min(t_cells, rows - 1 - q);
    std::size_t x0 = 0;
    for (; x0 + kChunk <= nx; x0 += kChunk) {
      std::int16_t acc[kChunk];
      std::fill(acc, acc + kChunk, kInf16);
      for (int k = k_lo; k <= k_hi; ++k) {
        if (live[static_cast<std::size_t>(q + k) * chunks + x0 / kChunk] == 0) continue;
        const std::int16_t* src = in + nx * static_cast<std::size_t>(q + k) + x0;
        const auto kk = static_cast<std::int16_t>(k * k);
        for (std::size_t c = 0; c < kChunk; ++c) {
          acc[c] = std::min(acc[c], static_cast<std::int16_t>(src[c] + kk));
        }
      }
      for (std::size_t c = 0; c < kChunk; ++c) o[x0 + c] = acc[c] > cap ? kInf16 : acc[c];
    }
    for (std::size_t x = x0; x < nx; ++x) {
      std::int16_t best = kInf16;
      for (int k = k_lo; k <= k_hi; ++k) {
        const std::int16_t v = in[nx * static_cast<std::size_t>(q + k) + x];
        best = std::min(best, static_cast<std::int16_t>(v + k * k));
      }
      o[x] = best > cap ? kInf16 : best;
    }
  }
}

// Whether occupied cell (x, y, z) (index i) of the dims box has a free face neighbour.
inline bool HasFreeNeighbour(std::span<const std::uint8_t> occupancy, const Eigen::Vector3i& dims,
                             int x, int y, int z, std::size_t i) {
  const std::size_t snx = static_cast<std::size_t>(dims.x());
  const std::size_t snxy = snx * static_cast<std::size_t>(dims.y());
  return (x > 0 && occupancy[i - 1] == 0) || (x + 1 < dims.x() && occupancy[i + 1] == 0) ||
         (y > 0 && occupancy[i - snx] == 0) || (y + 1 < dims.y() && occupancy[i + snx] == 0) ||
         (z > 0 && occupancy[i - snxy] == 0) || (z + 1 < dims.z() && occupancy[i + snxy] == 0);
}

// Quantised signed distance (units of quantum = 1/inv_q) of every squared cell distance 0…cap.
std::vector<std::int16_t> QuantisedDistances(std::int32_t cap, double resolution,
                                             double max_distance, double inv_q) {
  std::vector<std::int16_t> table(static_cast<std::size_t>(cap) + 1);
  for (std::int32_t sq = 0; sq <= cap; ++sq) {
    const double d =
        std::min((std::sqrt(static_cast<double>(sq)) - 0.5) * resolution, max_distance);
    table[static_cast<std::size_t>(sq)] = static_cast<std::int16_t>(std::lround(d * inv_q));
  }
  return table;
}

// The ground plane below local layer `ground_layer`: every stored value becomes
// min(value, height of the cell centre above the plane).
void LowerToGroundPlane(std::int16_t* values, const Eigen::Vector3i& dims, int ground_layer,
                        double resolution, double max_distance, double inv_q) {
  const std::size_t layer_cells = static_cast<std::size_t>(dims.x()) * dims.y();
  for (int z = 0; z < dims.z(); ++z) {
    const double d = (z - ground_layer + 0.5) * resolution;
    if (d >= max_distance) break;
    const auto qd = static_cast<std::int16_t>(std::lround(std::max(d, -max_distance) * inv_q));
    std::int16_t* layer = values + layer_cells * z;
    for (std::size_t i = 0; i < layer_cells; ++i) layer[i] = std::min(layer[i], qd);
  }
}

// The bounding box [*lo, *hi] of the occupied cells without a free face neighbour; *hi has a
// negative coordinate when there is none.
void DeepCellBox(std::span<const std::uint8_t> occupancy, const Eigen::Vector3i& dims,
                 Eigen::Vector3i* lo, Eigen::Vector3i* hi) {
  const std::size_t snx = static_cast<std::size_t>(dims.x());
  const std::size_t snxy = snx * static_cast<std::size_t>(dims.y());
  *lo = dims;
  *hi = Eigen::Vector3i::Constant(-1);
  for (int z = 0; z < dims.z(); ++z) {
    for (int y = 0; y < dims.y(); ++y) {
      const std::size_t row =
          snx * static_cast<std::size_t>(y) + snxy * static_cast<std::size_t>(z);
      for (int x = 0; x < dims.x(); ++x) {
        const std::size_t i = row + static_cast<std::size_t>(x);
        if (occupancy[i] == 0 || HasFreeNeighbour(occupancy, dims, x, y, z, i)) continue;
        const Eigen::Vector3i c(x, y, z);
        *lo = lo->cwiseMin(c);
        *hi = hi->cwiseMax(c);
      }
    }
  }
}

}  // namespace

// ---------------------------------------------------------------- options

const Fields<EsdfOptions>& EsdfFields() {
  static const Fields<EsdfOptions> fields =
      Fields<EsdfOptions>()
          .Number("max_distance", &EsdfOptions::max_distance, {0.0, 30.0, true, false},
                  "truncation distance (m): distances are exact up to it and clamped beyond; "
                  "above the planner's `clearance`")
          .Flag("use_inflated_occupancy", &EsdfOptions::use_inflated_occupancy,
                "build from the inflated occupancy instead of the raw hits");
  return fields;
}

void EsdfOptions::Validate(const std::string& origin) const { EsdfFields().Check(*this, origin); }

EsdfOptions EsdfOptions::FromYaml(const YamlMap& map) { return EsdfFields().Read(map); }

// ---------------------------------------------------------------- builder

Esdf EsdfBuilder::Build(const LocalMap& map, const Eigen::AlignedBox3d& box_W,
                        const EsdfOptions& options) {
  options.Validate();
  if (box_W.isEmpty() || !box_W.min().allFinite() || !box_W.max().allFinite()) {
    throw std::invalid_argument("Esdf::Build: the box must be finite and non-empty");
  }
  CellIndex lo = map.CellOf(box_W.min());
  const CellIndex hi = map.CellOf(box_W.max()) + CellIndex::Ones();  // exclusive
  const bool ground = map.options().ground_is_obstacle;
  const int ground_z = map.ground_cell_z(options.use_inflated_occupancy);
  if (ground && lo.z() >= ground_z && lo.z() < hi.z()) {
    // Include one layer of ground cells when the ground is within the truncation distance, so
    // the interpolation near the ground sees it.
    const double gap_cells = lo.z() - ground_z;
    if (gap_cells * map.resolution() < options.max_distance) lo.z() = ground_z - 1;
  }
  const Eigen::Vector3i dims = hi - lo;
  if ((dims.array() <= 0).any() ||
      static_cast<double>(dims.x()) * dims.y() * dims.z() > static_cast<double>(kMaxCells)) {
    throw std::invalid_argument("Esdf::Build: the box must hold between 1 and 2^26 cells");
  }
  // The ground enters analytically (distance to a plane), not as occupied cells: that keeps the
  // transform's work to the sensed obstacles and gives the same distances.
  map.ExtractOccupancy(lo, dims, options.use_inflated_occupancy, &occupancy_,
                       /*include_ground=*/false);
  // Compute does not touch occupancy_, so it can be passed straight through.
  return Compute(lo.cast<double>() * map.resolution(), map.resolution(), dims, occupancy_, options,
                 ground ? std::optional<int>(ground_z - lo.z()) : std::nullopt);
}

Esdf EsdfBuilder::FromOccupancy(const Eigen::Vector3d& origin_W, double resolution,
                                const Eigen::Vector3i& dims,
                                std::span<const std::uint8_t> occupancy,
                                const EsdfOptions& options) {
  return Compute(origin_W, resolution, dims, occupancy, options, std::nullopt);
}

Esdf EsdfBuilder::Compute(const Eigen::Vector3d& origin_W, double resolution,
                          const Eigen::Vector3i& dims, std::span<const std::uint8_t> occupancy,
                          const EsdfOptions& options, std::optional<int> ground_layer) {
  options.Validate();
  if (!(resolution > 0.0) || !std::isfinite(resolution) || !origin_W.allFinite() ||
      (dims.array() <= 0).any() ||
      static_cast<double>(dims.x()) * dims.y() * dims.z() > static_cast<double>(kMaxCells)) {
    throw std::invalid_argument(
        "Esdf::FromOccupancy: need resolution > 0, a finite origin and 1 to 2^26 cells");
  }
  const std::size_t n = static_cast<std::size_t>(dims.x()) * dims.y() * dims.z();
  if (occupancy.size() != n) {
    throw std::invalid_argument("Esdf::FromOccupancy: occupancy holds " +
                                std::to_string(occupancy.size()) + " cells, dims need " +
                                std::to_string(n));
  }

  Esdf esdf;
  esdf.origin_W_ = origin_W;
  esdf.dims_ = dims;
  esdf.res_ = resolution;
  esdf.inv_res_ = 1.0 / resolution;
  esdf.max_distance_ = options.max_distance;
  esdf.quantum_ = options.max_distance / kQuantumSteps;
  esdf.values_.resize(n);

  // Truncation in cells: squared distances above cap need not be exact (they clamp anyway).
  const int t_cells = static_cast<int>(std::ceil(options.max_distance / resolution + 0.5)) + 1;
  const std::int32_t cap = t_cells * t_cells;
  std::size_t n_occupied = 0;
  for (std::uint8_t o : occupancy) n_occupied += o != 0 ? 1 : 0;
  // Quantised signed distance for a squared cell distance; a table for the small exact values.
  const double inv_q = 1.0 / esdf.quantum_;
  const std::vector<std::int16_t> table =
      QuantisedDistances(cap, resolution, options.max_distance, inv_q);
  const auto q_max = static_cast<std::int16_t>(std::lround(options.max_distance * inv_q));
  if (n_occupied == 0) {
    std::fill(esdf.values_.begin(), esdf.values_.end(), q_max);
  } else {
    // Outside: squared distance to the nearest occupied centre, for every cell.
    SquaredEdt(occupancy.data(), dims, true, cap, &outside_);
    for (std::size_t i = 0; i < n; ++i) {
      if (occupancy[i] == 0) {
        const std::int32_t sq = outside_[i];
        esdf.values_[i] = sq > cap ? q_max : table[static_cast<std::size_t>(sq)];
      } else {
        esdf.values_[i] = static_cast<std::int16_t>(-table[1]);  // nearest free centre 1 cell away
      }
    }
    FillDeepCells(occupancy, dims, t_cells, table, q_max, esdf.values_.data());
  }
  if (ground_layer.has_value()) {
    LowerToGroundPlane(esdf.values_.data(), dims, *ground_layer, resolution, options.max_distance,
                       inv_q);
  }
  return esdf;
}

void EsdfBuilder::FillDeepCells(std::span<const std::uint8_t> occupancy,
                                const Eigen::Vector3i& dims, int t_cells,
                                const std::vector<std::int16_t>& table, std::int16_t q_max,
                                std::int16_t* values) {
  // Inside: an occupied cell with a free face neighbour is exactly one cell from free space.
  // The others ("deep" cells) get an exact transform of the free set over their bounding box
  // widened by the truncation (cells outside the box count as not free).
  const std::int32_t cap = t_cells * t_cells;
  const std::size_t snx = static_cast<std::size_t>(dims.x());
  const std::size_t snxy = snx * static_cast<std::size_t>(dims.y());
  Eigen::Vector3i deep_lo;
  Eigen::Vector3i deep_hi;
  DeepCellBox(occupancy, dims, &deep_lo, &deep_hi);
  if ((deep_hi.array() < 0).any()) return;
  const Eigen::Vector3i sub_lo = (deep_lo.array() - t_cells).max(0).matrix();
  const Eigen::Vector3i sub_hi = (deep_hi.array() + t_cells).min(dims.array() - 1).matrix();
  const Eigen::Vector3i sub_dims = sub_hi - sub_lo + Eigen::Vector3i::Ones();
  const std::size_t sub_nx = static_cast<std::size_t>(sub_dims.x());
  const std::size_t sub_nxy = sub_nx * static_cast<std::size_t>(sub_dims.y());
  sub_occupancy_.resize(sub_nxy * static_cast<std::size_t>(sub_dims.z()));
  auto full_index = [&](int x, int y, int z) {
    return static_cast<std::size_t>(x) + snx * static_cast<std::size_t>(y) +
           snxy * static_cast<std::size_t>(z);
  };
  for (int z = 0; z < sub_dims.z(); ++z) {
    for (int y = 0; y < sub_dims.y(); ++y) {
      const std::uint8_t* src =
          occupancy.data() + full_index(sub_lo.x(), sub_lo.y() + y, sub_lo.z() + z);
      std::copy(src, src + sub_nx,
                sub_occupancy_.data() + sub_nx * static_cast<std::size_t>(y) +
                    sub_nxy * static_cast<std::size_t>(z));
    }
  }
  // Obstacles are a few cells thick, so the inside distances are short: a transform truncated
  // at kInsideProbeCells reads the same free centres and gives the same squared distances up to
  // its own cap, and only where a deep cell finds no free centre within it does the transform
  // run again to the full truncation. (A cell with a free face neighbour keeps its one-cell value
  // whatever the transform says, below.)
  // Visits the occupied cells of the sub-box with their squared inside distance, their full-box
  // coordinates and index, until fn returns false.
  auto for_each_occupied = [&](auto&& fn) {
    for (int z = 0; z < sub_dims.z(); ++z) {
      for (int y = 0; y < sub_dims.y(); ++y) {
        for (int x = 0; x < sub_dims.x(); ++x) {
          const std::size_t si = static_cast<std::size_t>(x) +
                                 sub_nx * static_cast<std::size_t>(y) +
                                 sub_nxy * static_cast<std::size_t>(z);
          if (sub_occupancy_[si] == 0) continue;
          const int fx = sub_lo.x() + x;
          const int fy = sub_lo.y() + y;
          const int fz = sub_lo.z() + z;
          if (!fn(inside_[si], fx, fy, fz, full_index(fx, fy, fz))) return;
        }
      }
    }
  };
  const int t_probe = std::min(t_cells, kInsideProbeCells);
  SquaredEdt(sub_occupancy_.data(), sub_dims, false, t_probe * t_probe, &inside_);
  if (t_probe < t_cells) {
    bool complete = true;
    for_each_occupied([&](std::int32_t sq, int fx, int fy, int fz, std::size_t fi) {
      complete = sq <= t_probe * t_probe || HasFreeNeighbour(occupancy, dims, fx, fy, fz, fi);
      return complete;
    });
    if (!complete) SquaredEdt(sub_occupancy_.data(), sub_dims, false, cap, &inside_);
  }
  for_each_occupied([&](std::int32_t sq, int fx, int fy, int fz, std::size_t fi) {
    // Cells with a free face neighbour keep their exact one-cell value (that neighbour may
    // lie outside the sub-box).
    if (sq > 1 && HasFreeNeighbour(occupancy, dims, fx, fy, fz, fi)) return true;
    values[fi] = sq > cap ? static_cast<std::int16_t>(-q_max)
                          : static_cast<std::int16_t>(-table[static_cast<std::size_t>(sq)]);
    return true;
  });
}

void EsdfBuilder::SquaredEdtWindowed(const std::uint8_t* occupancy, const Eigen::Vector3i& dims,
                                     bool target, int t_cells, std::vector<std::int32_t>* out) {
  const std::size_t nx = static_cast<std::size_t>(dims.x());
  const int ny = dims.y();
  const int nz = dims.z();
  const std::size_t nxy = nx * static_cast<std::size_t>(ny);
  const std::size_t n = nxy * static_cast<std::size_t>(nz);
  const auto cap = static_cast<std::int16_t>(t_cells * t_cells);
  grid16_.resize(n);
  std::int16_t* g = grid16_.data();

  RowPass(occupancy, nx, static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz), target,
          t_cells, kInf16, g);

  plane16_.resize(nx * static_cast<std::size_t>(std::max(ny, nz)));
  live_.resize(nx / kChunk * static_cast<std::size_t>(std::max(ny, nz)));
  if (ny > 1) {
    for (int z = 0; z < nz; ++z) {
      std::int16_t* slab = g + nxy * static_cast<std::size_t>(z);
      std::copy(slab, slab + nxy, plane16_.data());
      WindowedPass(plane16_.data(), slab, nx, ny, nx, t_cells, cap, live_.data());
    }
  }
  if (nz > 1) {
    for (int y = 0; y < ny; ++y) {
      std::int16_t* base = g + nx * static_cast<std::size_t>(y);
      for (int z = 0; z < nz; ++z) {
        const std::int16_t* row = base + nxy * static_cast<std::size_t>(z);
        std::copy(row, row + nx, plane16_.data() + nx * static_cast<std::size_t>(z));
      }
      WindowedPass(plane16_.data(), base, nx, nz, nxy, t_cells, cap, live_.data());
    }
  }
  out->resize(n);
  std::int32_t* d = out->data();
  for (std::size_t i = 0; i < n; ++i) d[i] = g[i] == kInf16 ? kInfSq : g[i];
}

void EsdfBuilder::SquaredEdt(const std::uint8_t* occupancy, const Eigen::Vector3i& dims,
                             bool target, std::int32_t cap, std::vector<std::int32_t>* out) {
  const int t_cells = static_cast<int>(std::lround(std::sqrt(static_cast<double>(cap))));
  if (t_cells * t_cells == cap && cap <= kMaxWindowedCap) {
    SquaredEdtWindowed(occupancy, dims, target, t_cells, out);
    return;
  }
  const int nx = dims.x();
  const int ny = dims.y();
  const int nz = dims.z();
  const std::size_t snx = static_cast<std::size_t>(nx);
  const std::size_t snxy = snx * static_cast<std::size_t>(ny);
  const std::size_t n = snxy * static_cast<std::size_t>(nz);
  out->resize(n);
  std::int32_t* g = out->data();

  RowPass(occupancy, snx, static_cast<std::size_t>(ny) * static_cast<std::size_t>(nz), target,
          t_cells, kInfSq, g);

  // Passes along y and z on transposed slabs, so that every line is contiguous.
  const int n_max = std::max({nx, ny, nz});
  slab_.resize(snx * static_cast<std::size_t>(std::max(ny, nz)));
  line_d_.resize(static_cast<std::size_t>(n_max));
  hull_v_.resize(static_cast<std::size_t>(n_max));
  hull_fv_.resize(static_cast<std::size_t>(n_max));
  hull_z_.resize(static_cast<std::size_t>(n_max) + 1);
  // Transforms the lines of a slab of `rows` rows (each nx values, `row_stride` apart in g).
  auto slab_pass = [&](std::int32_t* base, int rows, std::size_t row_stride) {
    std::int32_t* t = slab_.data();
    const std::size_t srows = static_cast<std::size_t>(rows);
    for (int r = 0; r < rows; ++r) {
      const std::int32_t* src = base + row_stride * static_cast<std::size_t>(r);
      for (int x = 0; x < nx; ++x) t[static_cast<std::size_t>(x) * srows + static_cast<std::size_t>(r)] = src[x];
    }
    for (int x = 0; x < nx; ++x) {
      std::int32_t* line = t + static_cast<std::size_t>(x) * srows;
      // A constant line (all zero, all without site, or any constant) is its own transform.
      bool constant = true;
      for (int i = 1; i < rows; ++i) constant &= line[i] == line[0];
      if (constant) continue;
      LowerEnvelope(line, rows, line_d_.data(), hull_v_.data(), hull_fv_.data(), hull_z_.data(),
                    cap);
      std::copy(line_d_.data(), line_d_.data() + rows, line);
    }
    for (int r = 0; r < rows; ++r) {
      std::int32_t* dst = base + row_stride * static_cast<std::size_t>(r);
      for (int x = 0; x < nx; ++x) dst[x] = t[static_cast<std::size_t>(x) * srows + static_cast<std::size_t>(r)];
    }
  };
  if (ny > 1) {
    for (int z = 0; z < nz; ++z) slab_pass(g + snxy * static_cast<std::size_t>(z), ny, snx);
  }
  if (nz > 1) {
    for (int y = 0; y < ny; ++y) slab_pass(g + snx * static_cast<std::size_t>(y), nz, snxy);
  }
}

// ---------------------------------------------------------------- field

Esdf Esdf::Build(const LocalMap& map, const Eigen::AlignedBox3d& box_W,
                 const EsdfOptions& options) {
  EsdfBuilder builder;
  return builder.Build(map, box_W, options);
}

Esdf Esdf::FromOccupancy(const Eigen::Vector3d& origin_W, double resolution,
                         const Eigen::Vector3i& dims, std::span<const std::uint8_t> occupancy,
                         const EsdfOptions& options) {
  EsdfBuilder builder;
  return builder.FromOccupancy(origin_W, resolution, dims, occupancy, options);
}

bool Esdf::Contains(const Eigen::Vector3d& p_W) const {
  return CoversCells((p_W - origin_W_) * inv_res_);
}

bool Esdf::CoversCells(const Eigen::Vector3d& u) const {
  if (values_.empty()) return false;
  for (int k = 0; k < 3; ++k) {
    if (!(u[k] >= 0.0 && u[k] <= dims_[k])) return false;
  }
  return true;
}

double Esdf::CellDistance(const Eigen::Vector3i& idx) const {
  QT_DEMAND((idx.array() >= 0).all() && (idx.array() < dims_.array()).all(),
            "Esdf::CellDistance: index outside the box");
  const std::size_t i = static_cast<std::size_t>(idx.x()) +
                        static_cast<std::size_t>(dims_.x()) *
                            (static_cast<std::size_t>(idx.y()) +
                             static_cast<std::size_t>(dims_.y()) * idx.z());
  return values_[i] * quantum_;
}

Eigen::Vector3d Esdf::CellCenter(const Eigen::Vector3i& idx) const {
  return origin_W_ + (idx.cast<double>().array() + 0.5).matrix() * res_;
}

namespace {

// The 4×4×4 cell-centre samples that the cubic B-spline blends at a point: per axis the
// point's fraction t ∈ [0, 1) of a cell past the centre below it, the x indices and the start of
// every (y, z) row, all clamped to the box (the field continues constant beyond it).
struct Stencil {
  double t[3];
  std::size_t xi[4];
  const std::int16_t* row[4][4];  // [k (z)][j (y)]
  bool contiguous;                // xi[i] = xi[0] + i (no clamping in x)
};

// u: the coordinate in cells relative to the centre of cell 0 (cell centre i sits at
// origin + (i + 1/2)·res).
Stencil Locate(const Eigen::Vector3d& u, const Eigen::Vector3i& dims,
               const std::int16_t* values) {
  Stencil s;
  int base[3];
  for (int a = 0; a < 3; ++a) {
    const double fl = std::floor(u(a));
    s.t[a] = u(a) - fl;
    base[a] = static_cast<int>(fl) - 1;
  }
  const auto sy = static_cast<std::size_t>(dims.x());
  const std::size_t sz = sy * static_cast<std::size_t>(dims.y());
  s.contiguous = base[0] >= 0 && base[0] + 3 < dims.x();
  if (s.contiguous && base[1] >= 0 && base[1] + 3 < dims.y() && base[2] >= 0 &&
      base[2] + 3 < dims.z()) {
    // Inside the box on every axis (the common case): no clamping, rows a fixed stride apart.
    for (int i = 0; i < 4; ++i) s.xi[i] = static_cast<std::size_t>(base[0] + i);
    const std::int16_t* plane =
        values + sy * static_cast<std::size_t>(base[1]) + sz * static_cast<std::size_t>(base[2]);
    for (int k = 0; k < 4; ++k, plane += sz) {
      for (int j = 0; j < 4; ++j) s.row[k][j] = plane + sy * static_cast<std::size_t>(j);
    }
    return s;
  }
  for (int i = 0; i < 4; ++i) {
    s.xi[i] = static_cast<std::size_t>(std::clamp(base[0] + i, 0, dims.x() - 1));
  }
  for (int k = 0; k < 4; ++k) {
    const auto z = static_cast<std::size_t>(std::clamp(base[2] + k, 0, dims.z() - 1));
    for (int j = 0; j < 4; ++j) {
      const auto y = static_cast<std::size_t>(std::clamp(base[1] + j, 0, dims.y() - 1));
      s.row[k][j] = values + sy * y + sz * z;
    }
  }
  return s;
}

// The smallest of the 64 samples.
std::int16_t StencilMin(const Stencil& s) {
#if defined(__SSE2__)
  if (s.contiguous) {
    // Four samples of a row are 8 contiguous bytes: two rows per register, eight registers.
    auto pair = [&s](int k, int j) {
      return _mm_unpacklo_epi64(
          _mm_loadl_epi64(reinterpret_cast<const __m128i*>(s.row[k][j] + s.xi[0])),
          _mm_loadl_epi64(reinterpret_cast<const __m128i*>(s.row[k][j + 1] + s.xi[0])));
    };
    __m128i m = pair(0, 0);
    m = _mm_min_epi16(m, pair(0, 2));
    for (int k = 1; k < 4; ++k) {
      m = _mm_min_epi16(m, pair(k, 0));
      m = _mm_min_epi16(m, pair(k, 2));
    }
    m = _mm_min_epi16(m, _mm_shuffle_epi32(m, _MM_SHUFFLE(1, 0, 3, 2)));
    m = _mm_min_epi16(m, _mm_shuffle_epi32(m, _MM_SHUFFLE(2, 3, 0, 1)));
    m = _mm_min_epi16(m, _mm_shufflelo_epi16(m, _MM_SHUFFLE(2, 3, 0, 1)));
    return static_cast<std::int16_t>(_mm_extract_epi16(m, 0));
  }
#endif
  std::int16_t low = std::numeric_limits<std::int16_t>::max();
  for (int k = 0; k < 4; ++k) {
    for (int j = 0; j < 4; ++j) {
      for (int i = 0; i < 4; ++i) low = std::min(low, s.row[k][j][s.xi[i]]);
    }
  }
  return low;
}

// The spline at the stencil, in quantum units; with derivatives (in quantum units per cell)
// when `derivatives`: *g and the upper triangle of *h.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__SANITIZE_THREAD__)
__attribute__((target_clones("avx2", "default")))
#endif
double Blend(const Stencil& s, bool derivatives, Eigen::Vector3d* g, Eigen::Matrix3d* h) {
  // Per axis: the four B-spline basis weights around the point and their first and second
  // derivatives.
  double w[3][4], dw[3][4], ddw[3][4];
  for (int a = 0; a < 3; ++a) {
    const double t = s.t[a], t2 = t * t, t3 = t2 * t, r = 1.0 - t;
    w[a][0] = r * r * r / 6.0;
    w[a][1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
    w[a][2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
    w[a][3] = t3 / 6.0;
    dw[a][0] = -0.5 * r * r;
    dw[a][1] = 1.5 * t2 - 2.0 * t;
    dw[a][2] = -1.5 * t2 + t + 0.5;
    dw[a][3] = 0.5 * t2;
    ddw[a][0] = r;
    ddw[a][1] = 3.0 * t - 2.0;
    ddw[a][2] = -3.0 * t + 1.0;
    ddw[a][3] = t;
  }
  const std::size_t* xi = s.xi;
  // The tensor-product spline contracted one axis at a time: x, then y, then z. Value only
  // (line-search trial points): 16 + 4 + 1 dot products of length 4; with derivatives, the
  // contractions keep the derivative orders each output needs (≈330 multiply-adds in all).
  double value = 0.0;
  if (!derivatives) {
    for (int k = 0; k < 4; ++k) {
      double zk = 0.0;
      for (int j = 0; j < 4; ++j) {
        const std::int16_t* v = s.row[k][j];
        const double cx = v[xi[0]] * w[0][0] + v[xi[1]] * w[0][1] + v[xi[2]] * w[0][2] +
                          v[xi[3]] * w[0][3];
        zk += cx * w[1][j];
      }
      value += zk * w[2][k];
    }
    return value;
  }
  // After x: per (k, j) the row contracted with w, dw, ddw in x.
  // After y: per k, b[ox][oy] = Σ_j a[ox] · (w, dw, ddw)[oy] for ox + oy <= 2.
  g->setZero();
  h->setZero();
  for (int k = 0; k < 4; ++k) {
    double b00 = 0.0, b01 = 0.0, b02 = 0.0, b10 = 0.0, b11 = 0.0, b20 = 0.0;
    for (int j = 0; j < 4; ++j) {
      const std::int16_t* v = s.row[k][j];
      double a0 = 0.0, a1 = 0.0, a2 = 0.0;
      for (int i = 0; i < 4; ++i) {
        const double c = v[xi[i]];
        a0 += c * w[0][i];
        a1 += c * dw[0][i];
        a2 += c * ddw[0][i];
      }
      b00 += a0 * w[1][j];
      b01 += a0 * dw[1][j];
      b02 += a0 * ddw[1][j];
      b10 += a1 * w[1][j];
      b11 += a1 * dw[1][j];
      b20 += a2 * w[1][j];
    }
    value += b00 * w[2][k];
    (*g)(0) += b10 * w[2][k];
    (*g)(1) += b01 * w[2][k];
    (*g)(2) += b00 * dw[2][k];
    (*h)(0, 0) += b20 * w[2][k];
    (*h)(1, 1) += b02 * w[2][k];
    (*h)(2, 2) += b00 * ddw[2][k];
    (*h)(0, 1) += b11 * w[2][k];
    (*h)(0, 2) += b10 * dw[2][k];
    (*h)(1, 2) += b01 * dw[2][k];
  }
  return value;
}

}  // namespace

double Esdf::EvaluateWithHessian(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W,
                                 Eigen::Matrix3d* hess_W) const {
  double distance = 0.0;
  EvaluateWithHessianBelow(p_W, std::numeric_limits<double>::infinity(), &distance, grad_W,
                           hess_W);
  return distance;
}

bool Esdf::EvaluateWithHessianBelow(const Eigen::Vector3d& p_W, double threshold,
                                    double* distance, Eigen::Vector3d* grad_W,
                                    Eigen::Matrix3d* hess_W) const {
  const Eigen::Vector3d uc = (p_W - origin_W_) * inv_res_;
  if (!CoversCells(uc)) {
    if (!(max_distance_ < threshold)) return false;
    if (grad_W != nullptr) grad_W->setZero();
    if (hess_W != nullptr) hess_W->setZero();
    *distance = max_distance_;
    return true;
  }
  const Stencil s = Locate(uc - Eigen::Vector3d::Constant(0.5), dims_, values_.data());
  // The weights are nonnegative and sum to one, so the spline is at least its smallest sample;
  // the margin of 10⁻¹² of its size (either sign) covers the rounding of the weights and the
  // sums (≈ 10⁻¹⁵).
  if (threshold < std::numeric_limits<double>::infinity()) {
    const double low = static_cast<double>(StencilMin(s)) * quantum_;
    if (low - std::abs(low) * 1e-12 >= threshold) return false;
  }
  const bool derivatives = grad_W != nullptr || hess_W != nullptr;
  Eigen::Vector3d g;
  Eigen::Matrix3d h;
  double value = Blend(s, derivatives, &g, &h);
  if (!derivatives) {
    *distance = value * quantum_;
    return true;
  }
  value *= quantum_;
  g *= quantum_;
  h *= quantum_;
  h(1, 0) = h(0, 1);
  h(2, 0) = h(0, 2);
  h(2, 1) = h(1, 2);
  if (grad_W != nullptr) *grad_W = g * inv_res_;
  if (hess_W != nullptr) *hess_W = h * (inv_res_ * inv_res_);
  *distance = value;
  return true;
}

double Esdf::Evaluate(const Eigen::Vector3d& p_W, Eigen::Vector3d* grad_W) const {
  if (!Contains(p_W)) {
    if (grad_W != nullptr) grad_W->setZero();
    return max_distance_;
  }
  // Continuous index relative to cell centres; per axis the two neighbours, the weight of the
  // upper one and whether the weight moves with p (not in the clamped outer half-cells).
  int i0[3];
  int i1[3];
  double t[3];
  double dt[3];
  for (int k = 0; k < 3; ++k) {
    const double u = (p_W[k] - origin_W_[k]) * inv_res_ - 0.5;
    const double fl = std::floor(u);
    int c = static_cast<int>(fl);
    if (c < 0) {
      i0[k] = i1[k] = 0;
      t[k] = 0.0;
      dt[k] = 0.0;
    } else if (c >= dims_[k] - 1) {
      i0[k] = i1[k] = dims_[k] - 1;
      t[k] = 0.0;
      dt[k] = 0.0;
    } else {
      i0[k] = c;
      i1[k] = c + 1;
      t[k] = u - fl;
      dt[k] = inv_res_;
    }
  }
  const std::size_t sx = static_cast<std::size_t>(dims_.x());
  const std::size_t sxy = sx * static_cast<std::size_t>(dims_.y());
  auto at = [&](int x, int y, int z) {
    return static_cast<double>(values_[static_cast<std::size_t>(x) +
                                       sx * static_cast<std::size_t>(y) +
                                       sxy * static_cast<std::size_t>(z)]);
  };
  const double c000 = at(i0[0], i0[1], i0[2]);
  const double c100 = at(i1[0], i0[1], i0[2]);
  const double c010 = at(i0[0], i1[1], i0[2]);
  const double c110 = at(i1[0], i1[1], i0[2]);
  const double c001 = at(i0[0], i0[1], i1[2]);
  const double c101 = at(i1[0], i0[1], i1[2]);
  const double c011 = at(i0[0], i1[1], i1[2]);
  const double c111 = at(i1[0], i1[1], i1[2]);
  const double tx = t[0];
  const double ty = t[1];
  const double tz = t[2];
  // Interpolate along x, then y, then z.
  const double c00 = c000 + tx * (c100 - c000);
  const double c10 = c010 + tx * (c110 - c010);
  const double c01 = c001 + tx * (c101 - c001);
  const double c11 = c011 + tx * (c111 - c011);
  const double c0 = c00 + ty * (c10 - c00);
  const double c1 = c01 + ty * (c11 - c01);
  const double value = c0 + tz * (c1 - c0);
  if (grad_W != nullptr) {
    const double dz = (c1 - c0) * dt[2];
    const double dy = ((1.0 - tz) * (c10 - c00) + tz * (c11 - c01)) * dt[1];
    const double ddx00 = c100 - c000;
    const double ddx10 = c110 - c010;
    const double ddx01 = c101 - c001;
    const double ddx11 = c111 - c011;
    const double dx = ((1.0 - tz) * ((1.0 - ty) * ddx00 + ty * ddx10) +
                       tz * ((1.0 - ty) * ddx01 + ty * ddx11)) *
                      dt[0];
    *grad_W = Eigen::Vector3d(dx, dy, dz) * quantum_;
  }
  return value * quantum_;
}

}  // namespace quadtune::planning
