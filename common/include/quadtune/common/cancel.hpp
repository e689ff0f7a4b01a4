#pragma once
/// \file
/// Process-wide cancellation, for work that takes no cancel argument of its own (layout
/// generation inside a planner's PrepareMap). A signal handler (SIGINT, SIGTERM) or any code
/// calls RequestCancel(); long loops call ThrowIfCancelled(), which throws Cancelled once it was
/// requested. Commands catch Cancelled, leave their outputs consistent and exit with code 130.
///
/// Thread safety: every function is safe from any thread; RequestCancel() and CancelRequested()
/// are also async-signal-safe (a lock-free atomic flag).

#include <atomic>
#include <stdexcept>

namespace quadtune {

/// Thrown by ThrowIfCancelled() after RequestCancel().
class Cancelled : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The process-wide flag; engine::RunOptions::cancel may point at it.
std::atomic<bool>& CancelFlag() noexcept;
inline void RequestCancel() noexcept { CancelFlag().store(true, std::memory_order_relaxed); }
inline bool CancelRequested() noexcept { return CancelFlag().load(std::memory_order_relaxed); }
/// Throws Cancelled("<what> cancelled") when cancellation was requested.
void ThrowIfCancelled(const char* what);

/// Installs handlers for SIGINT and SIGTERM: the first signal requests cancellation, a second
/// one ends the process at once (exit code 130).
void InstallCancelSignalHandlers();

}  // namespace quadtune
