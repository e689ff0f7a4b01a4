#include "quadtune/common/cancel.hpp"

#include <unistd.h>

#include <csignal>
#include <string>

namespace quadtune {
namespace {
std::atomic<bool> g_cancel{false};
static_assert(std::atomic<bool>::is_always_lock_free);

void OnCancelSignal(int) {
  if (g_cancel.exchange(true)) _exit(130);
}
}  // namespace

std::atomic<bool>& CancelFlag() noexcept { return g_cancel; }

void ThrowIfCancelled(const char* what) {
  if (CancelRequested()) throw Cancelled(std::string(what) + " cancelled");
}

void InstallCancelSignalHandlers() {
  struct sigaction action {};
  action.sa_handler = OnCancelSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
}

}  // namespace quadtune
