#pragma once
/// \file
/// Runs the `quadtune` program under bounds the test harness enforces: an address-space limit
/// (RLIMIT_AS) set in the child, and a deadline after which the child is killed (SIGKILL). The
/// result holds the exit code, whether the deadline killed it, the seconds it ran and its peak
/// resident memory (from wait4), so a test can fail when a refusal is slow or large.
///
/// Thread safety: each BoundedChild is used by one thread.

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "cli_util.hpp"

namespace quadtune::test {

/// How a bounded child ended.
struct BoundedResult {
  int exit_code = -1;      ///< -1 when it did not exit normally
  int signal = 0;          ///< the signal that ended it (0 when it exited)
  bool killed_at_deadline = false;
  double seconds = 0.0;    ///< from the start (or from Signal(), when one was sent) to the end
  long peak_rss_mib = 0;   ///< peak resident memory of the child
  std::string err;         ///< its stderr
};

/// `quadtune args...` started with its address space limited to `address_space_mib`; stdout and
/// stderr go to `log` and `log`.err.
class BoundedChild {
 public:
  BoundedChild(const std::vector<std::string>& args, const std::filesystem::path& log,
               long address_space_mib)
      : err_(log.string() + ".err"), start_(std::chrono::steady_clock::now()) {
    std::vector<std::string> argv_s{QuadtuneBinary()};
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    const std::string out = log.string();
    const rlimit as{static_cast<rlim_t>(address_space_mib) << 20,
                    static_cast<rlim_t>(address_space_mib) << 20};
    pid_ = fork();
    if (pid_ == 0) {  // only async-signal-safe calls until exec
      const int o = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      const int e = open(err_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (o < 0 || e < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0) _exit(126);
      if (setrlimit(RLIMIT_AS, &as) != 0) _exit(126);
      execv(argv[0], argv.data());
      _exit(127);
    }
  }

  [[nodiscard]] pid_t pid() const { return pid_; }
  [[nodiscard]] bool Running() const { return pid_ > 0 && kill(pid_, 0) == 0; }

  /// Sends `sig`; the seconds of the result then count from here.
  void Signal(int sig) {
    start_ = std::chrono::steady_clock::now();
    kill(pid_, sig);
  }

  /// Waits for the child; after `deadline_s` seconds it is killed (SIGKILL) and reported so.
  BoundedResult Wait(double deadline_s) {
    BoundedResult r;
    int status = 0;
    rusage usage{};
    while (wait4(pid_, &status, WNOHANG, &usage) == 0) {
      if (Elapsed() > deadline_s) {
        r.killed_at_deadline = true;
        kill(pid_, SIGKILL);
        wait4(pid_, &status, 0, &usage);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    r.seconds = Elapsed();
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.signal = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
    r.peak_rss_mib = usage.ru_maxrss / 1024;  // ru_maxrss is in KiB on Linux
    r.err = ReadText(err_);
    return r;
  }

 private:
  double Elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

  std::string err_;
  std::chrono::steady_clock::time_point start_;
  pid_t pid_ = -1;
};

}  // namespace quadtune::test
