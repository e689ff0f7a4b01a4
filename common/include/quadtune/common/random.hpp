#pragma once
/// \file
/// Seeded random numbers that give the same sequence on every platform and standard library.
///
/// std::mt19937_64's output is fixed by the C++ standard, but std::uniform_real_distribution and
/// std::normal_distribution are not, so quadtune draws through the functions below. No component
/// uses a global or auto-seeded generator: every stochastic component takes an explicit seed, and
/// sub-streams (one per world, trial, particle …) come from DeriveSeed.
///
/// Thread safety: an Rng is a value; give each thread or task its own.

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <numbers>
#include <random>

namespace quadtune {

using Rng = std::mt19937_64;

/// SplitMix64 finaliser: a bijective scramble of 64 bits.
constexpr std::uint64_t Mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

/// Derives an independent seed for a sub-stream, e.g. DeriveSeed(seed, {trial, world}).
constexpr std::uint64_t DeriveSeed(std::uint64_t seed, std::initializer_list<std::uint64_t> ids) {
  std::uint64_t h = Mix64(seed);
  for (std::uint64_t id : ids) h = Mix64(h ^ Mix64(id + 0x632be59bd9b4e019ULL));
  return h;
}

/// Uniform double in [0, 1) with 53 random bits.
inline double Uniform01(Rng& rng) {
  return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

/// Uniform double in [lo, hi).
inline double Uniform(Rng& rng, double lo, double hi) { return lo + (hi - lo) * Uniform01(rng); }

/// Uniform integer in [lo, hi] (inclusive), unbiased.
inline std::int64_t UniformInt(Rng& rng, std::int64_t lo, std::int64_t hi) {
  // Unsigned arithmetic: hi − lo overflows a signed integer for spans beyond 2^63.
  const std::uint64_t span = static_cast<std::uint64_t>(hi) - static_cast<std::uint64_t>(lo) + 1ULL;
  if (span == 0) return static_cast<std::int64_t>(rng());  // full 64-bit range
  const std::uint64_t limit = UINT64_MAX - (UINT64_MAX % span);
  std::uint64_t r = rng();
  while (r >= limit) r = rng();
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(lo) + r % span);
}

/// Standard normal sample (Box–Muller, no cached second value, so draws are stateless).
inline double StandardNormal(Rng& rng) {
  double u1 = Uniform01(rng);
  while (u1 <= 0.0) u1 = Uniform01(rng);
  const double u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

/// Normal sample with mean `mu` and standard deviation `sigma`.
inline double Normal(Rng& rng, double mu, double sigma) { return mu + sigma * StandardNormal(rng); }

}  // namespace quadtune
