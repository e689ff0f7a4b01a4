#pragma once
/// \file
/// A command's result directory (`--out` of run, study and adapt): checked, created and locked
/// for the life of the command.
///
/// - A path that exists and is not a directory is refused (ConfigError naming it).
/// - An exclusive flock on OUT/.quadtune.lock is taken without waiting; when another process
///   holds it, the command is refused with a message naming the directory and that process's
///   pid. The kernel releases the lock when the holder exits, however it exits.
/// - A directory that already holds a run (results.sqlite, study.json or summary.json, at most
///   two folders deep) is refused unless `resume` (continue it) or `overwrite` (empty OUT first,
///   keeping only the lock file) is given; the message says which to use. A command with rules
///   of its own for what OUT holds (sweep) takes the lock only (`lock_only`).
///
/// Thread safety: one ResultDir per process and directory; not shared between threads.

#include <string>

namespace quadtune::cli {

/// What a command allows for a directory that already holds a run.
struct ResultDirPolicy {
  bool resume = false;         ///< continue the stored run (the command supports --resume)
  bool overwrite = false;      ///< remove the old run first
  bool resume_allowed = true;  ///< false: the command has no --resume (adapt)
  bool lock_only = false;      ///< create and lock OUT, whatever it holds
  std::string key = "--out";   ///< the option that named OUT, in refusals
};

class ResultDir {
 public:
  /// Creates `out` if needed, locks it and applies `policy` (see the file comment). Throws
  /// ConfigError(out, "--out", ...) when refused; nothing in OUT is changed then.
  ResultDir(const std::string& out, const ResultDirPolicy& policy);
  ~ResultDir();
  ResultDir(const ResultDir&) = delete;
  ResultDir& operator=(const ResultDir&) = delete;

  [[nodiscard]] const std::string& path() const { return out_; }

 private:
  std::string out_;
  int fd_ = -1;
};

/// Throws ConfigError(dir, key, ...) when `dir` exists and is not a directory (checked before
/// any work, so a blocked output path fails at once).
void CheckOutputDir(const std::string& dir, const std::string& key);
/// Throws ConfigError(file, key, ...) unless `file` can be created: its folder exists and
/// `file` is not a directory.
void CheckOutputFile(const std::string& file, const std::string& key);

/// True when `out` holds the results of an earlier run (see the file comment).
[[nodiscard]] bool HoldsRun(const std::string& out);
/// True when `out` is a directory that holds anything besides a ResultDir's lock file.
[[nodiscard]] bool HoldsFiles(const std::string& out);

}  // namespace quadtune::cli
