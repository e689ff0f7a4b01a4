#include "result_dir.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>

#include "quadtune/common/error.hpp"

namespace quadtune::cli {
namespace {

namespace fs = std::filesystem;
constexpr const char* kLockName = ".quadtune.lock";

[[noreturn]] void Refuse(const std::string& out, const std::string& key,
                         const std::string& message) {
  throw ConfigError(out, key, message);
}

/// The pid written into the lock file by its holder ("" when unreadable).
std::string HolderPid(int fd) {
  char buf[32] = {0};
  const ssize_t n = pread(fd, buf, sizeof(buf) - 1, 0);
  if (n <= 0) return "";
  std::string pid(buf, static_cast<std::size_t>(n));
  while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
  return pid;
}

}  // namespace

void CheckOutputDir(const std::string& dir, const std::string& key) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec)) {
    throw ConfigError(dir, key, "exists and is not a directory; give a directory path");
  }
}

void CheckOutputFile(const std::string& file, const std::string& key) {
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw ConfigError(file, key, "is a directory; give a file path");
  const fs::path parent = fs::path(file).parent_path();
  if (!parent.empty() && !fs::is_directory(parent, ec)) {
    throw ConfigError(file, key, "the folder '" + parent.string() + "' does not exist");
  }
  if (::access(parent.empty() ? "." : parent.c_str(), W_OK) != 0) {
    throw ConfigError(file, key,
                      "the folder '" + (parent.empty() ? std::string(".") : parent.string()) +
                          "' is not writable");
  }
}

bool HoldsRun(const std::string& out) {
  std::error_code ec;
  if (!fs::is_directory(out, ec)) return false;
  fs::recursive_directory_iterator it(out, fs::directory_options::skip_permission_denied, ec);
  for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (it.depth() >= 2) it.disable_recursion_pending();
    const std::string name = it->path().filename().string();
    if (name == "results.sqlite" || name == "study.json" || name == "summary.json") return true;
  }
  return false;
}

bool HoldsFiles(const std::string& out) {
  std::error_code ec;
  for (fs::directory_iterator it(out, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->path().filename() != kLockName) return true;
  }
  return false;
}

ResultDir::ResultDir(const std::string& out, const ResultDirPolicy& policy) : out_(out) {
  std::error_code ec;
  if (fs::exists(out, ec) && !fs::is_directory(out, ec)) {
    Refuse(out, policy.key, "exists and is not a directory; give a directory path");
  }
  fs::create_directories(out, ec);
  if (ec) Refuse(out, policy.key, "cannot create the directory: " + ec.message());
  const std::string lock_path = (fs::path(out) / kLockName).string();
  fd_ = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    Refuse(out, policy.key, std::string("cannot create the lock file: ") + std::strerror(errno));
  }
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const int err = errno;
    const std::string pid = HolderPid(fd_);
    ::close(fd_);
    fd_ = -1;
    if (err == EWOULDBLOCK) {
      Refuse(out, policy.key,
             "another quadtune process" + (pid.empty() ? "" : " (pid " + pid + ")") +
                 " is writing this result directory; wait for it to end or choose another " +
                 policy.key);
    }
    Refuse(out, policy.key, std::string("cannot lock the directory: ") + std::strerror(err));
  }
  try {
    if (!policy.lock_only && HoldsRun(out)) {
      if (policy.resume && policy.overwrite) Refuse(out, policy.key, "give --resume or --overwrite, not both");
      if (!policy.resume && !policy.overwrite) {
        Refuse(out, policy.key, policy.resume_allowed
                        ? "already holds a run; give --resume to continue it or --overwrite to "
                          "replace it"
                        : "already holds a run; give --overwrite to replace it or choose another "
                          "--out");
      }
      if (policy.overwrite) {
        for (const auto& entry : fs::directory_iterator(out)) {
          if (entry.path().filename() != kLockName) fs::remove_all(entry.path());
        }
      }
    }
  } catch (...) {
    ::close(fd_);
    fd_ = -1;
    throw;
  }
  // The holder's pid, for the message another process shows when refused.
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) == 0) {
    (void)!::pwrite(fd_, pid.data(), pid.size(), 0);
  }
}

ResultDir::~ResultDir() {
  if (fd_ >= 0) ::close(fd_);  // closing releases the flock
}

}  // namespace quadtune::cli
