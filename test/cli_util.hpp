#pragma once
/// \file
/// Helpers for tests that run the `quadtune` program end to end: make a fresh temporary directory,
/// run a command line, read the CSV files and check the figures it writes.

#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace quadtune::test {

/// The program the test runs (its target's quadtune_runs_cli() in test/CMakeLists.txt): the
/// `quadtune` program of this build, or for toy experiments `quadtune_test_cli`, the same program
/// with the test planners `toy` and `sleep` (test/support/toy_planners.hpp).
inline std::string QuadtuneBinary() { return QUADTUNE_CLI_PROGRAM; }

/// The `quadtune` program of this build (without the test planners).
inline std::string ProductionQuadtuneBinary() { return QUADTUNE_PROGRAM; }

/// The toy experiment file (test/support/toy.yaml; runs on QuadtuneBinary() as
/// `quadtune_test_cli`).
inline std::string ToyExperimentFile() {
  return std::string(QUADTUNE_SOURCE_DIR) + "/test/support/toy.yaml";
}

/// Runs QuadtuneBinary() with ARGS through the shell with its output in `log`; returns the exit status.
inline int RunQuadtune(const std::string& args, const std::filesystem::path& log) {
  const std::string cmd = QuadtuneBinary() + " " + args + " > '" + log.string() + "' 2>&1";
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

/// The whole text of a file ("" when it cannot be read).
inline std::string ReadText(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// An empty folder `name`_<process id> in the temporary directory: test programs running at the
/// same time (two checkouts, two ctest runs) never share one.
inline std::filesystem::path FreshTempDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

/// Size in bytes of a PNG file (0 when it is missing or not a PNG).
inline std::uintmax_t PngBytes(const std::filesystem::path& png) {
  std::ifstream in(png, std::ios::binary);
  char magic[8] = {};
  if (!in.read(magic, 8) || std::string(magic + 1, 3) != "PNG") return 0;
  return std::filesystem::file_size(png);
}

/// Rows of a CSV file (no quoted commas) as maps column → text.
inline std::vector<std::map<std::string, std::string>> ReadCsv(const std::filesystem::path& path) {
  std::ifstream in(path);
  auto split = [](const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ',')) out.push_back(item);
    return out;
  };
  std::vector<std::map<std::string, std::string>> rows;
  std::string line;
  if (!std::getline(in, line)) return rows;
  const std::vector<std::string> header = split(line);
  while (std::getline(in, line)) {
    const auto cells = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < cells.size(); ++i) row[header[i]] = cells[i];
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace quadtune::test
