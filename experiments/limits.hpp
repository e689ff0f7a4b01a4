#pragma once
/// \file
/// Ceilings of the command line's counts and thread numbers, checked before any work, and the
/// check of a thread count against the process's address-space limit (`ulimit -v`).
///
/// Thread safety: constants, and a function without shared state.

#include <CLI/CLI.hpp>
#include <string>

namespace quadtune::cli {

/// Why engine::kMaxThreads bounds `--threads`.
inline constexpr const char* kThreadsWhy = "worker threads of one process; more run on more ranks";
/// `sweep --points`: base rows N of the Saltelli design (N·(d+2) points).
inline constexpr int kMaxSweepPoints = 1 << 20;
/// `sweep --maps`: maps K every point flies on.
inline constexpr int kMaxSweepMaps = 1000;
/// `sweep --queries`: recorded queries Q re-solved per θ_s.
inline constexpr int kMaxSweepQueries = 1 << 20;
/// Why a count is bounded, as the refusals and docs/hardening.md say it.
inline constexpr const char* kQueuedWhy = "all are queued at once";
inline constexpr const char* kBenchThreadsWhy = "bench runs every thread count from 1 up";
inline constexpr const char* kSoakWhy = "10 million flights take over a day at 100 flights/s";
/// `bench --max-threads`: bench runs every count from 1 up, so its time grows with the square.
inline constexpr int kMaxBenchThreads = 256;
/// `bench --flights`: flights per thread count, all queued at once.
inline constexpr int kMaxBenchFlights = 100000;
/// `bench --resolves`: re-solves per thread count, all queued at once.
inline constexpr int kMaxBenchResolves = 1000000;
/// `bench --soak`: flights of the soak benchmark (its queue holds one task per thread).
inline constexpr int kMaxSoakFlights = 10000000;
/// Address space one worker thread is counted to take (its stack, its allocator's thread-local
/// segments, a planner's solver workspace): `run experiments/tiny.yaml` fits 200 threads in
/// `ulimit -v 4194304` and 40 in `ulimit -v 1048576`, about 18 MiB a thread above 300 MiB.
inline constexpr long kThreadReserveMib = 20;
/// Address space the program takes before its worker threads (libraries, maps, the store).
inline constexpr long kProgramReserveMib = 512;

/// A CLI11 check of a count option: a decimal integer in [lo, hi], refused as "got V; allowed: an
/// integer in [lo, hi] (why)".
[[nodiscard]] CLI::Validator CountIn(long lo, long hi, const std::string& why);

/// Throws ConfigError(file, key, ...) when `threads` workers would not fit the address-space
/// limit (RLIMIT_AS, `ulimit -v`) at kThreadReserveMib each above kProgramReserveMib: the
/// refusal names the value, the limit and the largest count that fits (a thread the system
/// cannot create would abort the process). No limit set → no check. `key` is the option
/// (`--threads`, file "") or the file's key (`threads`).
void CheckThreadsFitAddressSpace(int threads, const std::string& file, const std::string& key);
/// The check for a command's `--threads` (when > 0) or else the `threads` of `file`.
void CheckThreadsFitAddressSpace(int option_threads, int file_threads, const std::string& file);

}  // namespace quadtune::cli
