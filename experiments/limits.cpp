#include "limits.hpp"

#include <sys/resource.h>

#include <algorithm>
#include <charconv>
#include <string>

#include "quadtune/common/error.hpp"

namespace quadtune::cli {

CLI::Validator CountIn(long lo, long hi, const std::string& why) {
  const std::string allowed =
      "allowed: an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "] (" + why + ")";
  return CLI::Validator(
      [lo, hi, allowed](std::string& text) -> std::string {
        long v = 0;
        const auto [end, err] = std::from_chars(text.data(), text.data() + text.size(), v);
        const bool whole = err == std::errc() && end == text.data() + text.size();
        if (whole && v >= lo && v <= hi) return "";
        return "got '" + text + "'; " + allowed;
      },
      "INT in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

void CheckThreadsFitAddressSpace(int threads, const std::string& file, const std::string& key) {
  rlimit limit{};
  if (getrlimit(RLIMIT_AS, &limit) != 0 || limit.rlim_cur == RLIM_INFINITY) return;
  const long limit_mib = static_cast<long>(limit.rlim_cur >> 20);
  const long fit = std::max(0L, (limit_mib - kProgramReserveMib) / kThreadReserveMib);
  if (threads <= fit) return;
  throw ConfigError(file, key,
                    "got " + std::to_string(threads) + " threads; at most " + std::to_string(fit) +
                        " fit this process's address-space limit (ulimit -v " +
                        std::to_string(limit.rlim_cur >> 10) + " KiB): each worker takes about " +
                        std::to_string(kThreadReserveMib) + " MiB above the program's " +
                        std::to_string(kProgramReserveMib) +
                        " MiB; lower the thread count or raise the limit");
}

void CheckThreadsFitAddressSpace(int option_threads, int file_threads, const std::string& file) {
  if (option_threads > 0) return CheckThreadsFitAddressSpace(option_threads, "", "--threads");
  CheckThreadsFitAddressSpace(file_threads, file, "threads");
}

}  // namespace quadtune::cli
